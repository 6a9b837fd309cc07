"""P1 (quintic point-to-point) and P2 (C2 spline through via points): joint-space tasks.

P1: 6 joints rest to rest in 2 s, 1000 samples of q, q', q''. Ours (``core.joint.point_to_point.plan_joint``
and ``POST /v1/trajectories/joint``) beside roboticstoolbox ``jtraj`` and a plain numpy reference
(the closed-form rest-to-rest quintic ``q0 + d (10 s^3 - 15 s^4 + 6 s^5)`` by Horner's rule).

P2: 6 joints through 50 via points at given times (10 s), clamped at rest, 10,000 samples with two
derivatives. Ours (``core.joint.splines.plan_spline`` and ``POST /v1/trajectories/spline``) beside scipy
``CubicSpline`` fit plus three evaluations.

Every row is checked against the reference before it is timed (``assert_close``), so a fast row
that computes something else fails the run.
"""

from __future__ import annotations

import numpy as np

from bench.harness import Row, Table, http_row, optional
from core.joint.point_to_point import PointToPoint, plan_joint
from core.joint.splines import plan_spline

Q0 = np.array([0.0, -1.5, 1.5, 0.0, 0.5, 0.0])
Q1 = np.array([1.0, -1.0, 0.7, 1.2, -0.5, 0.3])
DURATION = 2.0
SAMPLES = 1000

VIA_POINTS = 50
SPLINE_SAMPLES = 10_000
SPLINE_DURATION = 10.0


def assert_close(name: str, got: tuple, want: tuple, tol: float = 1e-9) -> None:
    for g, w in zip(got, want, strict=True):
        err = float(np.abs(np.asarray(g) - np.asarray(w)).max())
        if not err <= tol * max(1.0, float(np.abs(w).max())):
            raise AssertionError(f"{name} differs from the reference by {err:.3g}")


def quintic_reference(q0: np.ndarray, q1: np.ndarray, T: float, n: int) -> tuple:
    """Plain numpy: the rest-to-rest quintic at ``n`` times, positions, velocities, accelerations."""
    t = np.linspace(0.0, T, n)
    s = (t / T)[:, None]
    d = q1 - q0
    q = q0 + d * (s * s * s * (10.0 + s * (-15.0 + 6.0 * s)))
    qd = (d / T) * (s * s * (30.0 + s * (-60.0 + 30.0 * s)))
    qdd = (d / T**2) * (s * (60.0 + s * (-180.0 + 120.0 * s)))
    return t, q, qd, qdd


def p1_quintic(client=None, url: str = "") -> Table:
    def ours() -> tuple:
        plan = plan_joint(
            "quintic", PointToPoint.create(Q0, Q1), duration=DURATION, samples=SAMPLES
        )
        tr = plan.trajectory
        return tr.times, tr.positions, tr.velocities, tr.accelerations

    def reference() -> tuple:
        return quintic_reference(Q0, Q1, DURATION, SAMPLES)

    want = reference()
    assert_close("ours (core)", ours(), want)
    rows = [
        Row("ours: core plan_joint", ours, note="validation, profile, sampling, checks"),
        Row("numpy reference (closed form, Horner)", reference),
    ]
    if client is not None:
        body = {
            "profile": "quintic",
            "start": {"positions": Q0.tolist()},
            "goal": {"positions": Q1.tolist()},
            "duration": DURATION,
            "samples": SAMPLES,
        }
        rows.append(http_row(client, url, "/v1/trajectories/joint", body, "ours: HTTP /joint"))
    missing = optional("roboticstoolbox")
    if missing:
        rows.append(Row("roboticstoolbox jtraj", unavailable=missing, peer=True))
    else:
        import roboticstoolbox as rtb

        t = want[0]

        def jtraj() -> tuple:
            tr = rtb.jtraj(Q0, Q1, t)
            return t, tr.q, tr.qd, tr.qdd

        assert_close("jtraj", jtraj(), want)
        rows.append(Row("roboticstoolbox jtraj", jtraj, peer=True))
    return Table(
        "P1",
        f"quintic, 6 joints, rest to rest in {DURATION:g} s, {SAMPLES} samples of q, q', q''",
        "numpy reference (closed form, Horner)",
        rows,
        notes=[
            "All rows agree to 1e-9 (checked before timing). The HTTP row is the full round trip: "
            "request JSON, validation, planning, response JSON (1000 points), decoding.",
        ],
    )


def spline_problem() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Knot times (50,), via points (50, 6) (a seeded random walk), sample times (10,000,)."""
    rng = np.random.default_rng(7)
    waypoints = np.cumsum(rng.uniform(-0.3, 0.3, (VIA_POINTS, 6)), axis=0)
    knots = np.linspace(0.0, SPLINE_DURATION, VIA_POINTS)
    return knots, waypoints, np.linspace(0.0, SPLINE_DURATION, SPLINE_SAMPLES)


def p2_spline(client=None, url: str = "") -> Table:
    from scipy.interpolate import CubicSpline

    knots, waypoints, t = spline_problem()

    def ours() -> tuple:
        tr = plan_spline(waypoints, times=knots, boundary="clamped", samples=SPLINE_SAMPLES)
        return tr.trajectory.positions, tr.trajectory.velocities, tr.trajectory.accelerations

    def scipy_fit_eval() -> tuple:
        spline = CubicSpline(knots, waypoints, bc_type="clamped", axis=0)
        return spline(t), spline(t, 1), spline(t, 2)

    assert_close("ours (core)", ours(), scipy_fit_eval())
    notes = ["The core row agrees with scipy to 1e-9 (checked before timing)."]
    rows = [
        Row("ours: core plan_spline", ours, note="validation, fit, sampling, checks"),
        Row("scipy CubicSpline fit + 3 evaluations", scipy_fit_eval, peer=True),
    ]
    if client is not None:
        body = {
            "waypoints": waypoints.tolist(),
            "times": knots.tolist(),
            "boundary": "clamped",
            "samples": SPLINE_SAMPLES,
        }
        rows.append(http_row(client, url, "/v1/trajectories/spline", body, "ours: HTTP /spline"))
        size = len(client.post(f"{url}/v1/trajectories/spline", json=body).content)
        notes.append(f"The HTTP row's response is {size / 1e6:.1f} MB of JSON.")
    return Table(
        "P2",
        f"C2 spline, 6 joints through {VIA_POINTS} via points at given times, clamped, "
        f"{SPLINE_SAMPLES} samples with two derivatives",
        "scipy CubicSpline fit + 3 evaluations",
        rows,
        notes=notes,
    )


VMAX, AMAX, JMAX = np.pi, 10.0, 100.0


def p1_limits() -> Table:
    """P1b: rest to rest under velocity/acceleration limits (the duration is found, not given).
    Different algorithms, so different durations: informational, no target."""
    from core.limits import JointLimits

    limits = JointLimits(velocity=np.full(6, VMAX), acceleration=np.full(6, AMAX))
    rows = []
    for kind in ("quintic", "trapezoidal"):

        def ours(kind=kind):
            return plan_joint(kind, PointToPoint.create(Q0, Q1), limits, samples=SAMPLES)

        duration = ours().trajectory.duration
        rows.append(
            Row(f"ours: core plan_joint {kind}", ours, extra={"duration [s]": f"{duration:.3f}"})
        )
    missing = optional("ruckig")
    if missing:
        rows.append(Row("ruckig (jerk-limited, time-optimal)", unavailable=missing, peer=True))
    else:
        from ruckig import InputParameter, Ruckig, Trajectory

        def ruck():
            otg, inp, traj = Ruckig(6), InputParameter(6), Trajectory(6)
            inp.current_position, inp.target_position = Q0.tolist(), Q1.tolist()
            inp.max_velocity = [VMAX] * 6
            inp.max_acceleration = [AMAX] * 6
            inp.max_jerk = [JMAX] * 6
            otg.calculate(inp, traj)
            return traj, [traj.at_time(t) for t in np.linspace(0.0, traj.duration, SAMPLES)]

        rows.append(
            Row(
                "ruckig (jerk-limited, time-optimal)",
                ruck,
                peer=True,
                extra={"duration [s]": f"{ruck()[0].duration:.3f}"},
                note=f"jerk limit {JMAX:g} rad/s^3; sampled by `at_time` per point",
            )
        )
    return Table(
        "P1b",
        f"rest to rest under limits ({VMAX:.4g} rad/s, {AMAX:g} rad/s^2), shortest duration, "
        f"{SAMPLES} samples (different profiles: informational)",
        "ours: core plan_joint quintic",
        rows,
        columns=("duration [s]",),
    )


def p2_limits() -> Table:
    """P2b: through the P2 via points under limits, times found (ours: knot times allocated so the
    C2 spline keeps the limits; toppra: time-optimal parametrization of a spline path through the
    same points). Different problems, so different durations: informational, no target."""
    from core.limits import JointLimits

    _, waypoints, _ = spline_problem()
    limits = JointLimits(velocity=np.full(6, VMAX), acceleration=np.full(6, AMAX))

    def ours():
        tr = plan_spline(waypoints, limits=limits, samples=SPLINE_SAMPLES).trajectory
        return tr.duration, tr.accelerations

    def extra(duration: float, acc: np.ndarray) -> dict[str, str]:
        return {
            "duration [s]": f"{duration:.2f}",
            "peak acceleration / limit": f"{np.abs(acc).max() / AMAX:.3f}",
        }

    rows = [Row("ours: core plan_spline, times allocated", ours, extra=extra(*ours()))]
    missing = optional("toppra")
    if missing:
        rows.append(Row("toppra TOPPRA (const-accel parametrizer)", unavailable=missing, peer=True))
    else:
        import toppra
        import toppra.algorithm
        import toppra.constraint

        toppra.setup_logging("WARNING")
        vlim = np.column_stack([np.full(6, -VMAX), np.full(6, VMAX)])
        alim = np.column_stack([np.full(6, -AMAX), np.full(6, AMAX)])

        def topp():
            path = toppra.SplineInterpolator(np.linspace(0.0, 1.0, len(waypoints)), waypoints)
            constraints = [
                toppra.constraint.JointVelocityConstraint(vlim),
                toppra.constraint.JointAccelerationConstraint(alim),
            ]
            algo = toppra.algorithm.TOPPRA(constraints, path, parametrizer="ParametrizeConstAccel")
            traj = algo.compute_trajectory()
            t = np.linspace(0.0, traj.duration, SPLINE_SAMPLES)
            traj(t), traj(t, 1)
            return traj.duration, traj(t, 2)

        rows.append(
            Row(
                "toppra TOPPRA (const-accel parametrizer)",
                topp,
                peer=True,
                extra=extra(*topp()),
                note="path: toppra's spline through the points at uniform path parameters",
            )
        )
    return Table(
        "P2b",
        f"through the P2 via points under limits ({VMAX:.4g} rad/s, {AMAX:g} rad/s^2), times "
        f"found, {SPLINE_SAMPLES} samples (different problems: informational)",
        "ours: core plan_spline, times allocated",
        rows,
        columns=("duration [s]", "peak acceleration / limit"),
        unit="ms",
    )


def p1_jerk(client=None, url: str = "") -> Table:
    """P1c: 6 joints jerk-limited rest to rest, time-optimal, 1000 samples of q, q', q''. Ours
    (``plan_joint("jerk_limited")``: validation, Ruckig, vectorized sampling of its phases, exact
    peaks, checks) beside Ruckig called directly and sampled with its own ``at_time``. Target: ours
    <= 1.5x Ruckig direct (issue 17)."""
    from core.limits import JointLimits

    missing = optional("ruckig")
    if missing:
        return Table("P1c", "jerk-limited (ruckig not installed)", "", [])
    from ruckig import InputParameter, Ruckig, Trajectory

    limits = JointLimits(
        velocity=np.full(6, VMAX), acceleration=np.full(6, AMAX), jerk=np.full(6, JMAX)
    )
    motion = PointToPoint.create(Q0, Q1)

    def ours() -> tuple:
        tr = plan_joint("jerk_limited", motion, limits, samples=SAMPLES).trajectory
        return tr.times, tr.positions, tr.velocities, tr.accelerations

    def ruckig_direct() -> tuple:
        otg, inp, traj = Ruckig(6), InputParameter(6), Trajectory(6)
        inp.current_position, inp.target_position = Q0.tolist(), Q1.tolist()
        inp.max_velocity = [VMAX] * 6
        inp.max_acceleration = [AMAX] * 6
        inp.max_jerk = [JMAX] * 6
        otg.calculate(inp, traj)
        t = np.linspace(0.0, traj.duration, SAMPLES)
        q, qd, qdd = (np.array(x) for x in zip(*(traj.at_time(x) for x in t), strict=True))
        return t, q, qd, qdd

    want = ruckig_direct()
    assert_close("ours (core)", ours(), want)
    rows = [
        Row("ruckig direct + at_time per sample", ruckig_direct, peer=True),
        Row(
            "ours: core plan_joint jerk_limited", ours, note="validation, Ruckig, sampling, checks"
        ),
    ]
    if client is not None:
        body = {
            "profile": "jerk_limited",
            "start": {"positions": Q0.tolist()},
            "goal": {"positions": Q1.tolist()},
            "limits": {"velocity": [VMAX] * 6, "acceleration": [AMAX] * 6, "jerk": [JMAX] * 6},
            "samples": SAMPLES,
        }
        rows.append(http_row(client, url, "/v1/trajectories/joint", body, "ours: HTTP /joint"))
    return Table(
        "P1c",
        f"jerk-limited, 6 joints, rest to rest, time-optimal ({VMAX:.4g} rad/s, {AMAX:g} "
        f"rad/s^2, {JMAX:g} rad/s^3), {SAMPLES} samples of q, q', q''",
        "ruckig direct + at_time per sample",
        rows,
        notes=[
            "The core row agrees with Ruckig's at_time to 1e-9 (checked before timing). Target "
            "(issue 17): ours <= 1.5x Ruckig direct.",
        ],
    )
