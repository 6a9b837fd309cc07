"""Resolved-rate control along the straight line: pseudo-inverse (``resolved_rate``) and damped
least squares as a QP (``resolved_rate_dls``), simulated tick by tick.

Ticks of ``dt = control_period`` exactly: a run ends on a whole tick, not at the profile's duration
T (the setpoint rests at the goal from T on; ``ceil(T / dt)`` ticks make the nominal run). Each tick:

1. The setpoint: pose on the path at ``s(tau)``, twist ``path.derivative(s) s'`` (``s'``: the mean
   rate of ``s`` over the tick, ``setpoint.tick_table``), where ``s(t)`` is the nominal profile
   every Cartesian method starts from (quintic for a fixed duration, else the speed-limited
   trapezoid of ``CartesianTask.speeds()``) without joint caps (the controller's business; where
   no duration is given, ``simulate`` re-times it for the joint accelerations:
   ``core.cartesian.rate.retime``) and ``tau`` is the path clock (below).
2. The task twist ``V = twist + K e`` with ``e = [p_d - p, log(R_d R^T)]``: the position error and
   the rotation vector of the orientation error, both in the base frame, which are the coordinates
   of the Jacobian's rows (tip-origin linear velocity, angular velocity, base frame); the SE3 log
   would mix the two through the screw axis and need an adjoint to match them. ``K =
   FEEDBACK_GAIN`` (closed-loop inverse kinematics, Siciliano et al., Robotics: Modelling, Planning
   and Control, 2009, sec. 3.7), capped at ``MAX_GAIN_PER_TICK / dt`` so the discrete error
   dynamics ``e+ = (1 - K dt) e`` stay well damped at long control periods.
3. Joint rates from the task rows of the Jacobian (all six for ``pose``, x and y for
   ``position_xy``).

   - ``resolved_rate`` (the notes' sec. 7.2): ``J^-1 V`` (square) or the least-squares ``J^+ V``.
     It refuses to step where the smallest singular value is below ``core.kinematics.SINGULAR_VALUE_THRESHOLD``
     (``Singularity``), where a rate exceeds its limit (``JointRateLimit``, the notes' warning) or
     where the step would leave the position limits (``JointLimit``), each with ``s``.
   - ``resolved_rate_dls`` (``core.cartesian.rate.dls_tick``): the QP of
     ``core.cartesian.rate.qp`` with ``lambda = damping(sigma_min)`` (at least
     ``REDUNDANCY_DAMPING`` for a redundant arm, so the step is the minimum-norm one); its rates
     always respect the velocity limits, the acceleration limits (the previous rates +- ``a_max
     dt``; not with ``allow_violations``) and the position limits with room to brake. Near a
     singularity the tool leaves the
     line (measured and reported). So that velocity bounds slow the tool down along the line rather
     than push it off the line, the path clock runs at ``tau' = kappa <= 1``: the largest rate that
     keeps the DLS rates of the feedforward twist within ``TIME_SCALE_MARGIN`` of the limits (online
     time scaling, as in Dahl & Nielsen, IEEE Trans. Robot. Autom. 6(5), 1990). ``resolved_rate``
     keeps ``kappa = 1``: it is the classic reference.
   Without a ``duration`` the rates are scaled down where the tool's own speeds ``|J_p qd|``,
   ``|J_w qd|`` would exceed the task's limits (the feedback term's share: ``steps.speed_scale``).
4. ``q += qd dt`` (explicit Euler; ``core.cartesian.rate.smooth`` turns the ticks into the returned
   C2 motion).

When the path clock has reached the end the setpoint rests at the goal and the run ends once the pose
error is within ``GOAL_FRACTION`` of the tolerances and every rate within one tick's acceleration
of rest; the run may go on past the nominal duration by
``max(SETTLE_TIME, SETTLE_FRACTION T)``. If it is then within the tolerances it ends there (with a
warning); otherwise the DLS fails with ``JointLimit`` (a joint held at its position limit),
``JointRateLimit`` (the velocity limits kept the path clock from the end), ``Singularity`` (stuck
where the damping is active: a singularity or the workspace boundary) or ``NoConvergence``.

``core.cartesian.rate.output`` turns the ticks into the response (sampling, partial prefixes, diagnostics).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from core.cartesian.rate.dls_tick import DlsTick, smoothing_margin
from core.cartesian.rate.pinv_tick import PinvTick
from core.cartesian.rate.qp import SINGULAR_REGION, RateLimits, check_solver
from core.cartesian.rate.retime import ACCELERATION_TRIGGER, joint_timing, peak_acceleration_ratio
from core.cartesian.rate.setpoint import LineSetpoint, PathSetpoint, SetpointClock, setpoint_for
from core.cartesian.rate.steps import first_limit, pose_error, stuck
from core.cartesian.rate.tick_qp import ExtraRows
from core.cartesian.rate.ticks import RateRun, TickController, TickLog
from core.cartesian.task import MAX_TICKS, CartesianTask
from core.cartesian.timing import nominal_profile
from core.cartesian.validate import validated_line
from core.errors import InputError, NoConvergence, PlanningError, TooLarge
from core.kinematics import task_rows
from core.path import Path
from core.timing import PathLaw as Profile

FEEDBACK_GAIN = 20.0
"""K [1/s]: pose-error feedback gain (error time constant 50 ms)."""
MAX_GAIN_PER_TICK = 0.5
"""Upper bound on ``K dt``."""
GOAL_FRACTION = 0.1
"""The run ends once the pose error is within this share of the position and orientation tolerance."""
SETTLE_TIME = 1.0
"""[s] Least time allowed after the nominal duration to reach the goal."""
SETTLE_FRACTION = 1.0
"""Time allowed after the nominal duration, as a share of it (when longer than ``SETTLE_TIME``)."""
SPEED_CAP_SHARE = 1.0 - 1e-4
"""The ticks keep the tool's speed limits with this share: the returned velocities blend the
rates of neighbouring ticks (``core.cartesian.rate.smooth``) under a Jacobian that turns between
them, which measured up to 3e-6 of the limit over it at 10 ms sampling."""
STALL_TIME = 0.5
"""[s] A run that ends short of the goal is stuck at a singularity when the smallest singular value
fell below the singular region within this time of its end: the DLS's acceleration-bounded rates
hover about a singular configuration (measured: the UR5 3 m out of reach swings with a period of
about 0.5 s, sigma between 0.01 and 0.12) rather than settle in it."""
_CHECK_EVERY = 256
"""Ticks between deadline checks."""
RATE_METHODS = ("resolved_rate", "resolved_rate_dls")


def nominal_timing(task: CartesianTask, line: Path) -> Profile:
    """s(t): quintic for ``task.duration``, else the speed-limited profile of ``task.speeds()``
    times ``SPEED_CAP_SHARE`` (the S-curve for ``speed_profile="s_curve"``:
    ``core.cartesian.timing.nominal_profile``)."""
    return nominal_profile(_shared_speeds(task), line)


def _shared_speeds(task: CartesianTask) -> CartesianTask:
    """``task`` with its tool speed limits times ``SPEED_CAP_SHARE`` (none with a duration): the
    clock the ticks follow stays under the cap they keep, so the cap never cuts the feedforward (a
    cut at cruise made the DLS lag, then catch up: 5 % over the s-curve's path jerk)."""
    if task.duration is not None:
        return task
    linear, angular = task.speeds()
    return replace(
        task,
        max_linear_speed=None if linear is None else linear * SPEED_CAP_SHARE,
        max_angular_speed=None if angular is None else angular * SPEED_CAP_SHARE,
    )


def simulate(task: CartesianTask, method: str, extra_rows: ExtraRows | None = None) -> RateRun:
    """Run the controller of ``method`` along the task's line (see the module docstring). Where no
    ``duration`` is given and the joints' acceleration limits held the run back, run it again on
    the clock ``core.cartesian.rate.retime.joint_timing`` slows for them along the joint path a run
    took: the run's own when its joints accelerated over ``ACCELERATION_TRIGGER`` of their limits
    (``resolved_rate``, and the DLS with ``allow_violations``); for the DLS, whose rates keep the
    limits, when it failed or (without extra rows: they leave the line on purpose) lagged off
    the tolerances, the path of a run without the acceleration box."""
    run = _simulate(task, method, extra_rows)
    if task.duration is not None:
        return run
    if method == "resolved_rate_dls" and not task.allow_violations:
        if extra_rows is not None or not _lagged(task, run):  # (rows leave the line on purpose)
            return run
        path = _simulate(task, method, extra_rows, boxed=False)
    else:
        limits = task.robot.acceleration_limits
        if run.failure is not None or peak_acceleration_ratio(run.rates, run.dt, limits) <= (
            ACCELERATION_TRIGGER
        ):
            return run
        path = run
    if path.failure is None:
        slower = joint_timing(_shared_speeds(task), validated_line(task), path.s, path.positions)
        if slower is not None:
            run = _simulate(task, method, extra_rows, slower.profile)
            run = replace(run, timing_warnings=slower.warnings)
    return run


def _lagged(task: CartesianTask, run: RateRun) -> bool:
    """Whether the DLS's acceleration box held ``run`` back: it failed to converge or strayed off
    the tolerances, its rate bounds were active where it first strayed, and from a little before
    there on it met no singular region (a stall at the rim or a singularity, a pinned joint, is no
    lag)."""
    if run.failure is not None and not isinstance(run.failure, NoConvergence):
        return False
    off = (run.tracking_position > task.position_tolerance) | (
        run.tracking_orientation > task.orientation_tolerance
    )
    strayed = np.flatnonzero(off[:-1])
    if not strayed.size:
        return False
    first = max(0, int(strayed[0]) - math.ceil(STALL_TIME / run.dt))
    active = run.active[first : int(strayed[0]) + 1].any()
    return bool(active and run.sigma[first:].min() >= SINGULAR_REGION)


def _simulate(
    task: CartesianTask,
    method: str,
    extra_rows: ExtraRows | None = None,
    timing: Profile | None = None,
    boxed: bool = True,
) -> RateRun:
    """One run of the controller of ``method`` on the clock ``timing`` (default ``nominal_timing``);
    the DLS bounds its rates by the acceleration limits when ``boxed`` (and the task does not
    ``allow_violations``).

    ``extra_rows`` adds inequality rows to each tick's DLS QP (``core.cartesian.rate.tick_qp.ExtraRows``:
    obstacle avoidance); OSQP only, and not with ``resolved_rate``. Planning failures end the run
    and are returned in ``failure``; malformed input (``InputError``), a run over ``MAX_TICKS``
    (``TooLarge``) and the deadline raise.

    The loop (``_loop``) keeps per-tick work to what each tick needs (issue 19, P5): arrays
    preallocated for the run and written in place (``TickLog``); setpoints tabulated per block of
    ticks while the clock runs at rate 1 (``SetpointClock``); pose error in Python floats; the
    controller's own tick in ``core.cartesian.rate.dls_tick`` / ``core.cartesian.rate.pinv_tick``;
    active-bound flags from the stored arrays after the loop.
    """
    if method not in RATE_METHODS:
        raise InputError(f"method must be one of {', '.join(RATE_METHODS)}", field=("method",))
    dt = float(task.control_period)
    if not math.isfinite(dt) or dt <= 0.0:
        raise InputError("control_period must be a finite number > 0 s", field=("control_period",))
    dls = method == "resolved_rate_dls"
    solver = check_solver(task.solver) if dls else ""
    if extra_rows is not None and not (dls and solver == "osqp"):
        raise InputError(
            "extra inequality rows need resolved_rate_dls with osqp", field=("method",)
        )
    line = validated_line(task)
    timing = nominal_timing(task, line) if timing is None else timing
    nominal = max(1, math.ceil(timing.duration / dt - 1e-9))
    total = nominal + math.ceil(max(SETTLE_TIME, SETTLE_FRACTION * timing.duration) / dt)
    if total > MAX_TICKS:
        raise TooLarge(
            f"{total} control ticks exceed the limit of {MAX_TICKS}; raise control_period",
            field=("control_period",),
        )
    setpoint = setpoint_for(line, timing, dt, nominal)
    log = TickLog(total + 1, task.robot.dof, with_bounds=dls)
    controller = _controller(task, method, log, setpoint, dt, solver, extra_rows, boxed)
    n, failure = _loop(task, line, setpoint, controller, log, total)
    return log.run(n, dt, nominal, float(timing.duration), controller.fallbacks, failure, dls)


def _controller(
    task: CartesianTask,
    method: str,
    log: TickLog,
    setpoint: LineSetpoint | PathSetpoint,
    dt: float,
    solver: str,
    extra_rows: ExtraRows | None,
    boxed: bool,
) -> TickController:
    """The controller of ``method`` for this run, with the tool's speed caps (none with a
    duration) and the feedback gain ``min(FEEDBACK_GAIN, MAX_GAIN_PER_TICK / dt)``."""
    robot, limits = task.robot, RateLimits.of(task.robot)
    rows, pose_task = task_rows(robot.task_space), robot.task_space == "pose"
    gain = min(FEEDBACK_GAIN, MAX_GAIN_PER_TICK / dt)
    lin_cap, ang_cap = task.speeds()  # the tool's speed limits (none with a duration)
    caps = (
        len(rows[rows < 3]),  # the linear rows: 0..2, or 0..1
        math.inf if lin_cap is None else float(lin_cap) * SPEED_CAP_SHARE,
        math.inf if ang_cap is None or not pose_task else float(ang_cap) * SPEED_CAP_SHARE,
    )
    if method == "resolved_rate":
        return PinvTick(robot, log, limits, rows, dt, gain, caps)
    # the largest unit twist along the path (one constant on a line; sampled densely on an
    # arc, 1 % added for the samples between), over the smallest velocity limit
    biggest = setpoint.max_unit[rows]
    room = 1.0 + 1e-6 if isinstance(setpoint, LineSetpoint) else 1.01
    twist_bound = math.sqrt(float(biggest @ biggest)) * room / float(limits.velocity.min())
    margin = smoothing_margin(task, limits, setpoint.end)
    boxed = boxed and not task.allow_violations  # (which accepts accelerations over the limits)
    return DlsTick(
        log, limits, rows, dt, gain, twist_bound, solver, extra_rows, caps, margin, boxed
    )


def _loop(
    task: CartesianTask,
    line: Path,
    setpoint: LineSetpoint | PathSetpoint,
    controller: TickController,
    log: TickLog,
    total: int,
) -> tuple[int, PlanningError | None]:
    """The ticks ``k = 0..``: setpoint, kinematics, pose error, the end test, the controller's
    step. Returns the number of ticks run and the failure that ended the run (or None)."""
    robot, dt = task.robot, float(task.control_period)
    rows = task_rows(robot.task_space)
    pose_task, all_rows, all_p = (
        robot.task_space == "pose",
        len(rows) == 6,
        len(rows[rows < 3]) == 3,
    )
    row_list, goal_p, goal_o = rows.tolist(), task.position_tolerance, task.orientation_tolerance
    clock, positions = SetpointClock(setpoint, total + 1), log.positions
    rest = np.asarray(robot.acceleration_limits, dtype=float) * dt  # a rate one tick from rest
    positions[0] = task.q_start
    q, unit, unit_twist, units = positions[0], None, np.zeros(0), []
    kinematics = robot.fk_jacobian_loop()  # one scratch space for the run (this thread only)
    for k in range(total + 1):
        if k % _CHECK_EVERY == 0:
            task.deadline.check("resolved-rate control")
        s, sd, p_d, R_d, u = clock.at(k)
        if u is not unit:  # per unit s' [1/s]; a line's is one object, set once
            unit, unit_twist = u, u[rows]
            units = unit_twist.tolist()
        T_now, J_now = kinematics(q)
        # (ndarray.dot: the same BLAS call as @ without the ufunc machinery, about 1 us less)
        M = R_d.dot(T_now[:3, :3].T).tolist() if pose_task else None
        e = pose_error(T_now[:3, 3].tolist(), p_d, M)
        log.s[k] = s
        err_p = math.sqrt(e[0] * e[0] + e[1] * e[1] + (e[2] * e[2] if all_p else 0.0))
        err_o = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        log.tracking_position[k], log.tracking_orientation[k] = err_p, err_o
        at_end = clock.tau >= setpoint.end - 0.5 * dt
        if at_end and err_p <= GOAL_FRACTION * goal_p and err_o <= GOAL_FRACTION * goal_o:
            if bool((np.abs(log.rates[k - 1]) <= rest).all()):  # (and the rates come to rest)
                return k + 1, None
        if k == total:
            if at_end and err_p <= goal_p and err_o <= goal_o:
                return k + 1, None
            first, held = None, None
            if isinstance(controller, DlsTick):  # (its joints stop short of a limit by a margin)
                held = controller.held_box()
                first = first_limit(positions[1 : k + 1], held[0], held[1], log.s)
            stall = max(0, k - math.ceil(STALL_TIME / dt))
            sigma = float(log.sigma[stall:k].min())  # (the DLS may hover)
            failure = stuck(
                robot, line, q, sigma, first, at_end, s, dt * k, held, positions[: k + 1]
            )
            return k + 1, failure
        # (zip without strict=True in the controllers, ~0.8 us less: the lengths are equal)
        e_task = e if all_rows else [e[i] for i in row_list]
        kappa = controller.step(k, q, J_now, e_task, s, sd, unit_twist, units)
        if controller.failure is not None:
            return k + 1, controller.failure
        q = positions[k + 1]
        clock.advance(kappa, dt)
    return total + 1, None
