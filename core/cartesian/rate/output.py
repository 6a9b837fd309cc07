"""From simulated control ticks to a response: the sampled trajectory, its checks and diagnostics.

``result_of`` turns a ``core.cartesian.rate.control.RateRun`` into a finished ``CartesianResult``:

- Sampling: ``sample_period`` or ``samples`` over the run. The returned motion is the C2 cubic
  spline of ``core.cartesian.rate.smooth``: the controller's velocity (each tick's rate reached by
  a ramp, half a tick late) smoothed on the returned times, so that velocities and accelerations
  are the exact derivatives of the returned positions (acceleration linear between points) and
  stay within the bounds the ticks kept; it ends at rest one tick after the last rates when those
  are within a tick's acceleration of zero (the run's end test asks for it), else braked below.
- Partial plans (``allow_partial``): the prefix ends where the failure happened (``resolved_rate``)
  or, for the DLS, at the furthest point along the line before the tool first left the tolerance
  band. The prefix is braked to rest along the same joint path: original timing up to ``u_b``, then
  a uniform deceleration of the path clock whose rate ``a`` keeps ``|qd_i| a <= a_max_i`` for the
  prefix's peak rates (the path's own curvature is not counted). ``fraction`` is the line parameter
  of the closest point to the tool's final pose.
- Obstacles (``resolved_rate_dls`` with an environment): where the velocity dampers pushed the tool
  out of the tolerance band because the line runs through an obstacle, the answer is that
  ``Collision`` (``core.cartesian.rate.obstacle``), as every other method gives it; a partial plan
  is then the run without dampers (on the line) up to its last clear tick, braked to rest.
- Ticks off the line (damping near a singularity, active rate bounds, lag): 422 ``Infeasible``
  naming the controller as the cause (``_strayed``), not the sampling, unless ``allow_violations``.
- Checks and measurements: ``core.cartesian.check.finish`` (limits, dense deviation, singular values),
  then the controller's own figures in ``diagnostics`` and what a client should know in ``warnings``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from core.cartesian.check import VIOLATION_SLACK, finish
from core.cartesian.partial import partial_warning
from core.cartesian.rate.control import GOAL_FRACTION
from core.cartesian.rate.obstacle import blocking_contact
from core.cartesian.rate.qp import SINGULAR_REGION
from core.cartesian.rate.smooth import smooth_motion, tick_velocity
from core.cartesian.rate.ticks import RateRun
from core.cartesian.rim import controller_exit
from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import Infeasible
from core.kinematics import Kinematics
from core.path import Path
from core.path.line import pose_error
from core.trajectory import Trajectory, sample_times

LABEL_CHECKS = 16
"""Points per returned interval at which ``configuration_changes`` reads the label."""
GOAL_CONFIGURATION_WARNING = 1e-3
"""[rad] End configuration farther than this from ``q_goal``: a warning."""
_CHUNK = 20_000


def result_of(task: CartesianTask, run: RateRun, method: str) -> CartesianResult:
    """The finished result of ``run``; raises ``run.failure`` unless ``task.allow_partial``
    (a stall at the workspace's rim restated as ``unreachable``: ``controller_exit``)."""
    line = task.line()
    if run.failure is not None:
        run = replace(run, failure=controller_exit(task.robot, line, run.failure, task.deadline))
    detour = None
    if method == "resolved_rate_dls" and task.clearance is not None:
        detour = blocking_contact(task, line, run, _along_line(task, line, run.positions)[1])
        if detour is not None and not task.allow_violations:
            # the answer of every method: the collision; a partial plan is the run on the line
            # (without dampers) up to its last clear tick
            run = replace(detour.free, failure=detour.failure)
    if run.failure is not None and not task.allow_partial:
        raise run.failure
    last = len(run.s) - 1
    if run.failure is None:
        m, fraction = last, 1.0
    else:
        closest, first_out = _along_line(task, line, run.positions)
        m = last
        if detour is not None and run.failure is detour.failure:
            m = max(1, min(detour.clear, first_out - 1))
        elif method == "resolved_rate_dls":  # up to where the tool first left the tolerance band
            m = int(np.argmax(closest[: max(first_out, 1)]))
        fraction = min(float(closest[m]), float(np.nextafter(1.0, 0.0)))
    trajectory, s_points = _sample(task, run, m, brake=run.failure is not None)
    result = CartesianResult(trajectory=trajectory, fraction=fraction, failure=run.failure)
    result = finish(task, result, s_points)
    if run.failure is None and not (task.allow_partial or task.allow_violations):
        strayed = _strayed(task, line, run)  # (the 200 rule's answer, naming the cause)
        if strayed is not None:
            raise strayed
    diagnostics = _diagnostics(task, run, method, result)
    warnings = _warnings(task, run, method, replace(result, diagnostics=diagnostics))
    if not task.keep_configuration:  # (with it, a change is 422 branch_flip in finish)
        changes = configuration_changes(task.robot, line, result.trajectory)
        diagnostics["configuration_changes"] = changes
        warnings += [
            f"the configuration changes from {c['from']} to {c['to']} at s={c['s']:.4f} "
            "(keep_configuration is false)"
            for c in changes
        ]
    result = replace(result, diagnostics=diagnostics)
    if detour is not None and run.failure is None:  # allow_violations: the detour is accepted
        warnings.append(f"the tool left the line to keep the clearance: {detour.failure.detail}")
    return replace(result, warnings=tuple(warnings))


def configuration_changes(robot: Kinematics, line: Path, traj: Trajectory) -> list[dict[str, Any]]:
    """Each change of configuration label along ``traj`` as ``{"s", "from", "to"}``: labels at
    the returned points and ``LABEL_CHECKS`` points of the cubic between each two (Hermite from
    the returned velocities: the returned motion), ``s`` the line parameter of the tool at the
    first point with the new label."""
    q, t = traj.positions, traj.times
    if robot.configuration(q[0]) is None or len(t) < 2:
        return []
    spline = CubicHermiteSpline(t, q, traj.velocities, axis=0)
    steps = np.arange(LABEL_CHECKS) / LABEL_CHECKS
    dense_t = np.append((t[:-1, None] + np.diff(t)[:, None] * steps).ravel(), t[-1])
    dense = spline(dense_t)
    labels = robot.configurations(dense)
    at = [i for i in range(1, len(labels)) if labels[i] != labels[i - 1]]
    if not at:
        return []
    s = line.deviation(robot.fk_many(dense[at])).s
    return [
        {"s": float(x), "from": str(labels[i - 1]), "to": str(labels[i])}
        for x, i in zip(s, at, strict=True)
    ]


def _along_line(task: CartesianTask, line, positions: np.ndarray) -> tuple[np.ndarray, int]:
    """Line parameter of the closest point to the tool at each tick ``(n,)``, and the first tick
    at which the tool is farther from the line than the tolerances (``n`` if never)."""
    s, first_out = [], len(positions)
    for i in range(0, len(positions), _CHUNK):
        dev = line.deviation(
            task.robot.fk_many(positions[i : i + _CHUNK]),
            task.position_tolerance,
            task.orientation_tolerance,
        )
        s.append(dev.s)
        out = np.flatnonzero(
            (dev.position > task.position_tolerance)
            | (dev.orientation > task.orientation_tolerance)
        )
        if out.size and first_out == len(positions):
            first_out = i + int(out[0])
    return np.concatenate(s), first_out


def _strayed(task: CartesianTask, line, run: RateRun) -> Infeasible | None:
    """``Infeasible`` where the controller's own ticks leave the tolerance band (the 200 rule's
    answer, but naming the controller, not the sampling, as the cause), else None. Skipped when
    every tick is within the tolerances of its setpoint (a point of the line)."""
    tol_p, tol_o = task.position_tolerance, task.orientation_tolerance
    if run.tracking_position.max() <= tol_p and run.tracking_orientation.max() <= tol_o:
        return None
    dev = line.deviation(task.robot.fk_many(run.positions), tol_p, tol_o)
    worst = np.maximum(dev.position / tol_p, dev.orientation / tol_o)
    k = int(np.argmax(worst))
    if worst[k] <= 1.0 + VIOLATION_SLACK:
        return None
    # the cause: what held between the first tick outside the band and the worst one
    out = np.flatnonzero(worst > 1.0 + VIOLATION_SLACK)
    span = slice(int(out[0]) if out.size else k, min(k, len(run.sigma) - 1) + 1)
    if span.start < span.stop and (run.sigma[span] < SINGULAR_REGION).any():
        why = f"damped near a singularity (smallest singular value {run.sigma[span].min():.2e})"
    elif span.start < span.stop and run.active[span].any():
        why = "its joint rate bounds (velocity, acceleration or position limits) were active"
    else:
        why = "it lagged behind the setpoint"
    return Infeasible(
        f"the controller's own ticks leave the line by up to {dev.position.max():.3g} m / "
        f"{dev.orientation.max():.3g} rad (tolerance {tol_p:g} m / {tol_o:g} rad) near "
        f"s={dev.s[k]:.4f}, where {why}: more samples would not help; ask for a longer duration "
        "or lower tool speeds, or set allow_violations to accept it",
        s=float(dev.s[k]),
        extra={
            "max_position_deviation": float(dev.position.max()),
            "max_orientation_deviation": float(dev.orientation.max()),
        },
    )


def _sample(
    task: CartesianTask, run: RateRun, m: int, brake: bool
) -> tuple[Trajectory, np.ndarray]:
    """Trajectory over ticks ``0..m`` and the setpoint s per point: the controller's velocity
    (``tick_velocity``, half a tick late) smoothed on the returned times (``smooth_motion``),
    ending at rest by a last ramp when the run's last rates are within one tick's acceleration,
    else (and when ``brake``) braked to rest by the path clock."""
    names, dt = tuple(task.robot.joint_names), run.dt
    if m == 0:  # nothing was executed: the arm stays where it is
        times = np.array([0.0, dt])
        zeros = np.zeros((2, run.positions.shape[1]))
        return Trajectory(times, run.positions[[0, 0]], zeros, zeros, names), np.zeros(2)
    step = np.asarray(task.robot.acceleration_limits, dtype=float) * dt
    to_rest = not brake and bool(np.all(np.abs(run.rates[m - 1]) <= step * (1.0 + 1e-9)))
    tau, w = tick_velocity(run.rates, dt, m, to_rest)
    u_end = float(tau[-1])
    u_b, a = u_end, 0.0
    peak = np.abs(run.rates[:m]).max(axis=0)
    if not to_rest and np.any(peak > 0):
        moving = peak > 0
        a = float(np.min(np.asarray(task.robot.acceleration_limits)[moving] / peak[moving]))
        u_b = u_end - 0.5 / a
        if u_b < 0.0:
            u_b, a = 0.0, 0.5 / u_end
    duration = u_end if a == 0.0 else u_b + 1.0 / a

    def clock(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # tau(t) and its rate
        after = np.maximum(t - u_b, 0.0)
        u = np.minimum(np.minimum(t, u_b) + after - 0.5 * a * after**2, u_end)
        return u, np.clip(1.0 - a * after, 0.0, 1.0)

    def velocity(t: np.ndarray) -> np.ndarray:
        u, du = clock(t)
        idx = np.clip(np.floor(u / dt).astype(int), 0, len(w) - 2)
        frac = np.clip(u / dt - idx, 0.0, 1.0)[:, None]
        return (w[idx] + frac * (w[idx + 1] - w[idx])) * du[:, None]

    times = sample_times(duration, task.sample_period, task.samples)
    positions, velocities, accelerations = smooth_motion(times, velocity, run.positions[0])
    # where the smoothing leaves the tool off the ticks' end by more than the run's own end test
    # (coarse returned points), it ends where the ticks' velocity takes the arm (braked or not)
    end = run.positions[0] + np.trapezoid(w, dx=dt, axis=0)
    off_p, off_o = pose_error(task.robot.fk(positions[-1]), task.robot.fk(end))
    if off_p > GOAL_FRACTION * task.position_tolerance or (
        off_o > GOAL_FRACTION * task.orientation_tolerance
    ):
        limits = (
            np.asarray(task.robot.velocity_limits),
            np.asarray(task.robot.acceleration_limits),
        )
        positions, velocities, accelerations = smooth_motion(
            times, velocity, run.positions[0], end, limits
        )
    velocities[0] = velocities[-1] = 0.0  # (rest: exactly, not to rounding)
    s_points = np.interp(clock(times)[0] - 0.5 * dt, np.arange(len(run.s)) * dt, run.s)
    return Trajectory(times, positions, velocities, accelerations, names), s_points


def _diagnostics(
    task: CartesianTask, run: RateRun, method: str, result: CartesianResult
) -> dict[str, Any]:
    """The controller's figures (JSON-serializable)."""
    steps = len(run.sigma)
    nominal = run.nominal_duration
    diag: dict[str, Any] = {
        "control_period": run.dt,
        "control_ticks": len(run.s),
        "nominal_duration": nominal,
        "settle_time": max(0.0, (len(run.s) - 1 - run.nominal_ticks) * run.dt),
        "max_tracking_error_position": float(run.tracking_position.max()),
        "max_tracking_error_orientation": float(run.tracking_orientation.max()),
        "min_singular_value_met": float(run.sigma.min()) if steps else None,
        "max_damping": float(run.damping.max()) if steps else 0.0,
        "active_limit_steps": int(run.active.sum()),
        "min_time_scale": float(run.time_scale.min()) if steps else 1.0,
        "time_scaled_steps": int((run.time_scale < 1.0).sum()),
        "goal_position_error": float(run.tracking_position[-1]),
        "goal_orientation_error": float(run.tracking_orientation[-1]),
    }
    dev = result.deviation
    if dev is not None:
        worst = np.maximum(
            dev.position / task.position_tolerance, dev.orientation / task.orientation_tolerance
        )
        diag["max_deviation_s"] = float(dev.s[int(np.argmax(worst))])
    if method == "resolved_rate_dls" and steps:
        diag.update(
            solver=task.solver,
            qp_iterations_median=float(np.median(run.iterations)),
            qp_iterations_max=int(run.iterations.max()),
            qp_solve_time_us_median=float(np.median(run.solve_time) * 1e6),
            qp_solve_time_us_max=float(run.solve_time.max() * 1e6),
            qp_fallback_steps=run.fallbacks,
        )
    return diag


def _warnings(task: CartesianTask, run: RateRun, method: str, result: CartesianResult) -> list[str]:
    """What a client should know: active limits, lag, damping, accepted deviation."""
    out: list[str] = list(run.timing_warnings)
    diag = result.diagnostics
    if diag["active_limit_steps"]:
        out.append(
            f"joint rate bounds (velocity, acceleration or position limits) were active in "
            f"{diag['active_limit_steps']} of {len(run.sigma)} control ticks"
        )
    if diag["time_scaled_steps"]:
        slowest = int(np.argmin(run.time_scale))
        out.append(
            f"joint velocity limits slowed the tool along the line, to "
            f"{100.0 * diag['min_time_scale']:.3g} % of the nominal speed at worst (near "
            f"s={run.s[slowest]:.3f})"
        )
    if diag["settle_time"] > 0.0 and run.failure is None:
        out.append(
            f"the goal was reached {diag['settle_time']:.3f} s after the nominal duration of "
            f"{diag['nominal_duration']:.3f} s"
        )
    if run.failure is None and (
        diag["goal_position_error"] > GOAL_FRACTION * task.position_tolerance
        or diag["goal_orientation_error"] > GOAL_FRACTION * task.orientation_tolerance
    ):
        out.append(
            f"the run ended {diag['goal_position_error']:.3g} m and "
            f"{diag['goal_orientation_error']:.3g} rad from the goal (within the tolerance; the "
            f"controller converges slowly here)"
        )
    sigma = diag["min_singular_value_met"]
    if diag["max_damping"] > 0.0 and sigma is not None and sigma < SINGULAR_REGION:
        out.append(
            f"damped near a singularity (smallest singular value {sigma:.2e}, "
            f"damping up to {diag['max_damping']:.3g})"
        )
    dev = result.deviation
    if dev is not None and (
        dev.max_position > task.position_tolerance
        or dev.max_orientation > task.orientation_tolerance
    ):
        out.append(
            f"accepted a deviation from the line of up to {dev.max_position:.3g} m and "
            f"{dev.max_orientation:.3g} rad (tolerance {task.position_tolerance:g} m, "
            f"{task.orientation_tolerance:g} rad), largest near s={diag['max_deviation_s']:.3f}"
        )
    if run.failure is not None:
        out.insert(0, partial_warning(result.fraction, run.failure))
    peak = result.trajectory.peak_acceleration
    limit = np.asarray(task.robot.acceleration_limits)
    if np.any(peak > limit):
        j = int(np.argmax(peak / limit))
        out.append(
            f"joint {task.robot.joint_names[j]} accelerates at up to {peak[j]:.3g} (limit "
            f"{limit[j]:.3g}): "
            + (
                "resolved_rate bounds joint rates, not accelerations"
                if method == "resolved_rate"
                else "allow_violations lets resolved_rate_dls exceed the acceleration limits"
            )
        )
    if task.q_goal is not None and run.failure is None:
        apart = float(np.abs(result.trajectory.positions[-1] - task.q_goal).max())
        if apart > GOAL_CONFIGURATION_WARNING:
            out.append(
                f"the run ended on another configuration than goal.positions (joints up to "
                f"{apart:.3g} apart): the controller follows the pose, not the joint goal"
            )
    if run.fallbacks:
        out.append(
            f"OSQP stopped short of its tolerance in {run.fallbacks} control ticks; those were "
            f"solved exactly by bounded least squares"
        )
    return out
