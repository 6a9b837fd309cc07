"""R1: retiming a fixed geometric joint path at the optimum, ours against toppra on the same path.

Five paths, each timed under joint velocity and acceleration limits by ours
(``core.timing.topp.time_optimal``) and by toppra 0.6.10 (``TOPPRA``, its default grid, the
constant-acceleration parametrizer) on the same q(s) (toppra's own ``SplineInterpolator`` for the
splines, which is the same cubic; our blended path handed to it through its geometric-path
interface):

- (a) the P2 via points (``bench.joint.spline_problem``: 50 points, 6 joints), ``spline``,
  3.142 rad/s and 10 rad/s^2;
- (b) the 10-LIN UR5 program's joint path (``bench/data/ten_lin_ur5_path.json``: 840 points of the
  program's answer), ``spline``, the UR5's limits;
- (c) a collision-free Panda path (``bench/data/collision_free_panda_path.json``: MotionBenchMaker
  cage 0001, RRT-Connect + shortcuts), ``blended`` with 0.05 rad corners, the Panda's limits;
- (d) and (e) the P2 via points' random walk continued to 100 and to 1000 points (the same seed:
  their first 50 points are (a)'s), ``spline``, (a)'s limits: the two ends of the target's
  100-1000 waypoint range ((e) is some 250 s of motion on about 20,000 grid intervals).

On the splines (a), (b), (d) a third row times the same path with joint jerk limits as well
(``core.timing.path_jerk``, informational: how much longer than time-optimal that is; no peer
follows a fixed path under jerk limits).

Columns: the duration, its ratio to toppra's, and the largest limit excess of each answer measured
here on a dense resampling in time (``DENSE`` points per grid interval of the answer: velocity and
acceleration over the limits, minus 1; 0 when within). Targets (issue 24): duration <= 1.02x
toppra's with 0 excess; compute time <= 1.0x toppra's for 100-1000 waypoints.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from bench.harness import ROOT, Row, Table, optional
from core.joint.blended_path import BlendedPath
from core.joint.spline_path import SplinePath
from core.timing.joint_path import JointPath
from core.timing.path_constraints import PathLimits
from core.timing.path_jerk import jerk_limited
from core.timing.topp import time_optimal

DENSE = 20
"""Resampling points per grid interval of an answer when its excess is measured."""
WALKS = (100, 1000)
"""Points of the longer random walks (d) and (e)."""
JERK = {"a": 100.0, "b": 50.0, "d": 100.0}
"""Jerk limits [rad/s^3] of the jerk-limited rows: P1c's for the walks, ten times the UR5's
acceleration limit for (b) (Universal Robots publish none); (c) is blended (no jerk limits), (e)
takes seconds."""


def _load(name: str) -> dict:
    return json.loads((ROOT / "bench" / "data" / name).read_text())


def problems() -> list[tuple[str, str, JointPath, np.ndarray, np.ndarray, int]]:
    """(key, title, path, velocity limits, acceleration limits, waypoints) of (a) to (e)."""
    from bench.joint import AMAX, VMAX, spline_problem
    from robots import registry

    _, via, _ = spline_problem()
    walk = {n: np.cumsum(np.random.default_rng(7).uniform(-0.3, 0.3, (n, 6)), axis=0)
            for n in WALKS}  # fmt: skip
    assert np.array_equal(walk[WALKS[0]][: len(via)], via)  # (a)'s points, continued
    ten = np.asarray(_load("ten_lin_ur5_path.json")["waypoints"])
    free = np.asarray(_load("collision_free_panda_path.json")["waypoints"])
    ur5, panda = registry.get("ur5"), registry.get("panda")
    return [
        ("a", "P2 via points, spline", SplinePath(via), np.full(6, VMAX), np.full(6, AMAX), len(via)),
        ("b", "10-LIN UR5 program's joint path, spline", SplinePath(ten), ur5.velocity_limits,
         ur5.acceleration_limits, len(ten)),
        ("c", "collision-free Panda path, blended 0.05 rad", BlendedPath(free, 0.05),
         panda.velocity_limits, panda.acceleration_limits, len(free)),
        *((key, "P2 via points' random walk continued, spline", SplinePath(walk[n]),
           np.full(6, VMAX), np.full(6, AMAX), n) for key, n in zip("de", WALKS, strict=True)),
    ]  # fmt: skip


def excess(sample, duration: float, grid: int, v: np.ndarray, a: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """Largest relative excess of |q'| over ``v`` or |q''| over ``a`` on ``DENSE * grid`` points
    evenly spread in time (0 when every limit holds)."""
    t = np.linspace(0.0, duration, DENSE * grid + 1)
    qd, qdd = sample(t)
    return max(0.0, float(max((np.abs(qd) / v).max(), (np.abs(qdd) / a).max())) - 1.0)


def r1_retime() -> list[Table]:
    missing = optional("toppra")
    tables = []
    for key, title, path, v, a, n in problems():
        limits = PathLimits(v, a)

        def ours(path=path, limits=limits):  # type: ignore[no-untyped-def]
            return time_optimal(path, limits)

        result = ours()
        ours_excess = excess(
            lambda t, r=result: r.sample(t)[1:], result.duration, len(result.switch_times) - 1, v, a
        )
        rows = [Row("ours: core time_optimal", ours)]
        extra = {"duration [s]": f"{result.duration:.4f}", "excess": f"{ours_excess:.2g}"}
        note = f"{len(result.switch_times) - 1} grid intervals"
        if missing:
            rows.append(Row("toppra TOPPRA", unavailable=missing, peer=True))
        else:
            topp, reference = _toppra(path, v, a, key, n)
            trajectory, grid = topp()
            toppra_excess = excess(
                lambda t, tr=trajectory: (tr(t, 1), tr(t, 2)), trajectory.duration, grid, v, a
            )
            extra["ratio to toppra"] = f"{result.duration / trajectory.duration:.4f}"
            rows.append(
                Row(
                    "toppra TOPPRA (const-accel parametrizer)",
                    topp,
                    peer=True,
                    extra={
                        "duration [s]": f"{trajectory.duration:.4f}",
                        "excess": f"{toppra_excess:.2g}",
                        "ratio to toppra": "1",
                    },
                    note=f"{grid} grid intervals; path: {reference}",
                )
            )
        rows[0].extra, rows[0].note = extra, note
        if key in JERK:
            rows.insert(1, _jerk_row(path, limits, np.full(path.dof, JERK[key]), result.duration))
        tables.append(
            Table(
                f"R1{key}",
                f"retime {title}, {n} waypoints, {path.dof} joints, to rest at both ends",
                "toppra TOPPRA (const-accel parametrizer)" if not missing else rows[0].name,
                rows,
                columns=("duration [s]", "ratio to toppra", "excess"),
                notes=[
                    "excess: the largest |q'| / limit or |q''| / limit minus 1 on a resampling "
                    f"of {DENSE} points per grid interval of each answer (0: within the limits); "
                    "for the jerk-limited row also the slope of q'' between the resampled points "
                    "over the jerk limit."
                ],
                unit="ms",
            )
        )
    return tables


def _jerk_row(path: JointPath, limits: PathLimits, jerk: np.ndarray, optimal: float) -> Row:
    """The same path with jerk limits too (``core.timing.path_jerk``): its duration over the
    time-optimal one and its excess, jerk included (slopes of q'' on the resampling)."""

    def run():  # type: ignore[no-untyped-def]
        return jerk_limited(path, limits, jerk)

    result = run()
    t = np.linspace(0.0, result.duration, DENSE * len(result.profile.s) + 1)
    _, qd, qdd = result.sample(t)
    slopes = np.abs(np.diff(qdd, axis=0)) / np.diff(t)[:, None]
    worst = max((np.abs(qd) / limits.velocity).max(), (np.abs(qdd) / limits.acceleration).max(),
                (slopes / jerk).max())  # fmt: skip
    return Row(
        f"ours: core jerk_limited, J = {jerk[0]:g} rad/s^3",
        run,
        extra={"duration [s]": f"{result.duration:.4f}", "excess": f"{max(0.0, worst - 1.0):.2g}"},
        note=f"{result.duration / optimal:.3f}x the time-optimal duration (informational)",
    )


def toppra_path(path: Any) -> Any:
    """``path`` (``path(s, order)``, ``dof``, ``length``: a ``JointPath`` or a program's
    ``ChunkPath``) through toppra's geometric-path interface."""
    import toppra.interpolator

    class Adapter(toppra.interpolator.AbstractGeometricPath):  # type: ignore[misc]
        def __call__(self, s, order=0):  # type: ignore[no-untyped-def]
            return path(np.atleast_1d(np.asarray(s, dtype=float)), order)

        @property
        def dof(self) -> int:
            return int(path.dof)

        @property
        def path_interval(self) -> np.ndarray:
            return np.array([0.0, path.length])

        @property
        def waypoints(self) -> None:
            return None

    return Adapter()


def _toppra(path: JointPath, v: np.ndarray, a: np.ndarray, key: str, n: int):  # type: ignore[no-untyped-def]
    import toppra
    import toppra.algorithm
    import toppra.constraint
    import toppra.interpolator

    toppra.setup_logging("WARNING")
    if isinstance(path, SplinePath):
        waypoints = path(path.knots)
        geometric = toppra.SplineInterpolator(path.knots, waypoints)
        reference = "toppra's SplineInterpolator (the same not-a-knot cubic in chord length)"
    else:
        geometric = toppra_path(path)
        reference = "our BlendedPath through toppra's geometric-path interface"
    constraints = [
        toppra.constraint.JointVelocityConstraint(np.column_stack([-v, v])),
        toppra.constraint.JointAccelerationConstraint(np.column_stack([-a, a])),
    ]

    def run():  # type: ignore[no-untyped-def]
        algo = toppra.algorithm.TOPPRA(constraints, geometric, parametrizer="ParametrizeConstAccel")
        trajectory = algo.compute_trajectory()
        return trajectory, len(algo.problem_data.gridpoints) - 1

    return run, reference
