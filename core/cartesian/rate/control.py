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
   - ``resolved_rate_dls``: the QP of ``core.cartesian.rate.qp`` with ``lambda = damping(sigma_min)`` (at
     least ``REDUNDANCY_DAMPING`` for a redundant arm, so the step is the minimum-norm one); its
     rates always respect the velocity and position limits. Near a singularity the tool leaves the
     line (measured and reported). So that velocity bounds slow the tool down along the line rather
     than push it off the line, the path clock runs at ``tau' = kappa <= 1``: the largest rate that
     keeps the DLS rates of the feedforward twist within ``TIME_SCALE_MARGIN`` of the limits (online
     time scaling, as in Dahl & Nielsen, IEEE Trans. Robot. Autom. 6(5), 1990). ``resolved_rate``
     keeps ``kappa = 1``: it is the classic reference.
   Without a ``duration`` the rates are scaled down where the tool's own speeds ``|J_p qd|``,
   ``|J_w qd|`` would exceed the task's limits (the feedback term's share: ``steps.speed_scale``).
4. ``q += qd dt`` (explicit Euler; the returned positions lie on this piecewise-linear path).

When the path clock has reached the end the setpoint rests at the goal and the run ends once the pose
error is within ``GOAL_FRACTION`` of the tolerances; the run may go on past the nominal duration by
``max(SETTLE_TIME, SETTLE_FRACTION T)``. If it is then within the tolerances it ends there (with a
warning); otherwise the DLS fails with ``JointLimit`` (a joint held at its position limit),
``JointRateLimit`` (the velocity limits kept the path clock from the end), ``Singularity`` (stuck
where the damping is active: a singularity or the workspace boundary) or ``NoConvergence``.

``core.cartesian.rate.output`` turns the ticks into the response (sampling, partial prefixes, diagnostics).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from core.cartesian.rate.qp import (
    REDUNDANCY_DAMPING,
    SINGULAR_REGION,
    RateLimits,
    build_dls_qp,
    check_solver,
    damping,
    solve_dls_qp,
)
from core.cartesian.rate.retime import ACCELERATION_TRIGGER, joint_timing, peak_acceleration_ratio
from core.cartesian.rate.setpoint import LineSetpoint, setpoint_for
from core.cartesian.rate.steps import (
    TIME_SCALE_MARGIN,
    clear_ticks,
    feedforward_ratio,
    first_limit,
    pinv_step,
    pose_error,
    singular_values,
    smallest_singular_value,
    speed_scale,
    stuck,
    svd,
    time_scale,
)
from core.cartesian.rate.tick_qp import DlsQpSolver, ExtraRows
from core.cartesian.task import MAX_TICKS, CartesianTask
from core.cartesian.timing import nominal_profile
from core.cartesian.validate import validated_line
from core.errors import (
    InputError,
    PlanningError,
    TooLarge,
)
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
ACTIVE_TOLERANCE = 1e-6
"""[rad/s] A rate this close to its bound counts as an active limit."""
_CHECK_EVERY = 256
_RECHECK = 16
"""Ticks between looks for the clear span (``clear_ticks``) while a joint is near a position limit."""
_FIRST_BLOCK, _BLOCK = 16, 1024
"""Setpoints tabulated per block of ticks: the first after a slowed tick, and the most (doubling)."""
RATE_METHODS = ("resolved_rate", "resolved_rate_dls")


@dataclass(frozen=True)
class RateRun:
    """The simulated control ticks of one run (n ticks, ``k = 0..n-1``; steps ``k = 0..n-2``).

    Attributes:
        dt: Control period [s].
        nominal_ticks: Ticks in the nominal duration (the first tick at or after its end).
        nominal_duration: Duration of the nominal profile s(t) [s].
        positions: Joint positions at each tick ``(n, dof)``.
        rates: Joint rates commanded from each tick on ``(n, dof)``; the last row is zero.
        s: Path parameter of the setpoint at each tick ``(n,)``.
        sigma: Smallest singular value of the task Jacobian at each step ``(n-1,)``.
        damping: lambda at each step ``(n-1,)`` (0 for ``resolved_rate``).
        time_scale: Rate of the path clock at each step ``(n-1,)`` (1: nominal speed).
        active: Whether a rate bound was active at each step ``(n-1,)``.
        iterations: QP iterations at each step ``(n-1,)`` (0 for ``resolved_rate``).
        solve_time: QP update and solve time [s] at each step ``(n-1,)``.
        fallbacks: Steps where OSQP stopped short and the exact bounded least squares took over.
        tracking_position: Distance [m] from the setpoint at each tick ``(n,)``.
        tracking_orientation: Angle [rad] from the setpoint at each tick ``(n,)``.
        failure: Why the run stopped short of the goal, or None.
        timing_warnings: Where the clock was slowed for the joint limits (``retime``).
    """

    dt: float
    nominal_ticks: int
    nominal_duration: float
    positions: np.ndarray
    rates: np.ndarray
    s: np.ndarray
    sigma: np.ndarray
    damping: np.ndarray
    time_scale: np.ndarray
    active: np.ndarray
    iterations: np.ndarray
    solve_time: np.ndarray
    fallbacks: int
    tracking_position: np.ndarray
    tracking_orientation: np.ndarray
    failure: PlanningError | None
    timing_warnings: tuple[str, ...] = ()


def nominal_timing(task: CartesianTask, line: Path) -> Profile:
    """s(t): quintic for ``task.duration``, else the speed-limited profile of ``task.speeds()``
    (the S-curve for ``speed_profile="s_curve"``: ``core.cartesian.timing.nominal_profile``)."""
    return nominal_profile(task, line)


def simulate(task: CartesianTask, method: str, extra_rows: ExtraRows | None = None) -> RateRun:
    """Run the controller of ``method`` along the task's line (see the module docstring); where
    no ``duration`` is given and the run's joints accelerate over ``ACCELERATION_TRIGGER`` of their
    limits, run it again on the clock ``core.cartesian.rate.retime.joint_timing`` slows for them."""
    run, limits = _simulate(task, method, extra_rows), task.robot.acceleration_limits
    if run.failure is None and task.duration is None:
        if peak_acceleration_ratio(run.rates, run.dt, limits) > ACCELERATION_TRIGGER:
            slower = joint_timing(task, validated_line(task), run.s, run.positions)
            if slower is not None:
                run = _simulate(task, method, extra_rows, slower.profile)
                run = replace(run, timing_warnings=slower.warnings)
    return run


def _simulate(task, method, extra_rows: ExtraRows | None = None, timing: Profile | None = None):
    """One run of the controller of ``method`` on the clock ``timing`` (default ``nominal_timing``).

    ``extra_rows`` adds inequality rows to each tick's DLS QP (``core.cartesian.rate.qp.ExtraRows``:
    obstacle avoidance); OSQP only, and not with ``resolved_rate``. Planning failures end the run
    and are returned in ``failure``; malformed input (``InputError``), a run over ``MAX_TICKS``
    (``TooLarge``) and the deadline raise.

    The loop keeps per-tick work to what each tick needs (issue 19, P5; every output equal to the
    previous loop's within 1e-12, iterations exactly): arrays preallocated for the run and written
    in place (rate bounds, rates, next positions); rate bounds left at the velocity limits and
    next positions unclipped over the ticks ``clear_ticks`` shows no position limit can bind; setpoints tabulated per block of ticks while
    the clock runs at rate 1; pose error, damping and path clock in Python floats; the smallest
    singular value from syev on the Gram matrix ``J J^T`` (gesdd near singularities, both without
    numpy's wrapper); the path-clock rate skipped where a norm bound, then
    a Cholesky solve, keep it at 1; one OSQP workspace updated in place; active-bound flags and the
    first pinned joint from the stored arrays after the loop.
    """
    if method not in RATE_METHODS:
        raise InputError(f"method must be one of {', '.join(RATE_METHODS)}", field=("method",))
    robot, dls = task.robot, method == "resolved_rate_dls"
    period = float(task.control_period)
    if not math.isfinite(period) or period <= 0.0:
        raise InputError("control_period must be a finite number > 0 s", field=("control_period",))
    limits = RateLimits.of(robot)
    lo_q, hi_q, vmax = limits.position[:, 0], limits.position[:, 1], limits.velocity
    solver = check_solver(task.solver) if dls else ""
    if extra_rows is not None and not (dls and solver == "osqp"):
        raise InputError(
            "extra inequality rows need resolved_rate_dls with osqp", field=("method",)
        )
    line = validated_line(task)
    timing = nominal_timing(task, line) if timing is None else timing
    nominal = max(1, math.ceil(timing.duration / period - 1e-9))
    dt = period
    total = nominal + math.ceil(max(SETTLE_TIME, SETTLE_FRACTION * timing.duration) / dt)
    if total > MAX_TICKS:
        raise TooLarge(
            f"{total} control ticks exceed the limit of {MAX_TICKS}; raise control_period",
            field=("control_period",),
        )
    setpoint = setpoint_for(line, timing, dt, nominal)
    rows, pose_task = task_rows(robot.task_space), robot.task_space == "pose"
    p_rows = rows[rows < 3]
    all_rows, all_p = len(rows) == 6, len(p_rows) == 3
    gain = min(FEEDBACK_GAIN, MAX_GAIN_PER_TICK / dt)
    lin_cap, ang_cap = task.speeds()  # the tool's speed limits (none with a duration)
    lin_cap = math.inf if lin_cap is None else float(lin_cap)
    ang_cap = math.inf if ang_cap is None or not pose_task else float(ang_cap)
    capped, p_list = lin_cap < math.inf or ang_cap < math.inf, len(p_rows)  # (rows 0..2 or 0..1)
    goal_p, goal_o = task.position_tolerance, task.orientation_tolerance
    capacity = 0 if extra_rows is None else int(extra_rows.capacity)
    qp = DlsQpSolver(robot.dof, extra_rows=capacity) if dls and solver == "osqp" else None
    floor = REDUNDANCY_DAMPING if robot.dof > len(rows) else 0.0
    # |qd_ff|_inf <= |twist| max_i S_i / (S_i^2 + lam^2) / min v_max (with room for rounding);
    # the largest unit twist along the path (one constant on a line; sampled densely on an arc,
    # 1 % added for the samples between)
    biggest = setpoint.max_unit[rows]
    margin = 1.0 + 1e-6 if isinstance(setpoint, LineSetpoint) else 1.01
    twist_bound = math.sqrt(float(biggest @ biggest)) * margin / float(vmax.min())
    row_list, unit, unit_twist, units = rows.tolist(), None, biggest, biggest.tolist()

    n, dof = total + 1, robot.dof
    positions, rates = np.zeros((n, dof)), np.zeros((n, dof))
    bounds = np.empty((n if dls else 0, 2, dof))  # (lower, upper) rate bounds of each step,
    bounds[:, 0], bounds[:, 1] = -vmax, vmax  # as they are while no position limit is in reach
    track_p, track_o = np.zeros(n), np.zeros(n)
    s_log, sigma, lam_log, scale = np.zeros(n), np.zeros(n), np.zeros(n), np.ones(n)
    its, times = np.zeros(n, dtype=np.int64), np.zeros(n)
    position_box, low_v = np.stack([lo_q, hi_q]), -vmax
    fallbacks, failure, tau, no_rows = 0, None, 0.0, ()
    positions[0] = task.q_start
    q = positions[0]
    nominal_clock, block_at, block_end, block_size = True, 0, 0, _FIRST_BLOCK
    wide, shift_lam, shift = len(rows) <= dof, 0.0, None
    clear_until, recheck = 0, 0  # ticks k < clear_until: bounds (-v_max, v_max), no clipping of q
    kinematics = robot.fk_jacobian_loop()  # one scratch space for the run (this thread only)
    clock = time.perf_counter
    for k in range(n):
        if k % _CHECK_EVERY == 0:
            task.deadline.check("resolved-rate control")
        if nominal_clock:  # setpoints tabulated a block of ticks at a time (while kappa = 1)
            if k >= block_end:
                count = min(block_size, n - k)
                block_s, block_sd, block_p, block_R, block_u = setpoint.block(tau, count)
                block_at, block_end, block_size = k, k + count, min(2 * block_size, _BLOCK)
            j = k - block_at
            s, sd, p_d, R_d, u = block_s[j], block_sd[j], block_p[j], block_R[j], block_u[j]
        else:
            s, sd, p_d, R_d, u = setpoint(tau)
            R_d = np.array(R_d).reshape(3, 3)
        if u is not unit:  # per unit s' [1/s]; a line's is one object, set once
            unit, unit_twist = u, u[rows]
            units = unit_twist.tolist()
        T_now, J_now = kinematics(q)
        # (ndarray.dot: the same BLAS call as @ without the ufunc machinery, about 1 us less)
        M = R_d.dot(T_now[:3, :3].T).tolist() if pose_task else None
        e = pose_error(T_now[:3, 3].tolist(), p_d, M)
        s_log[k] = s
        err_p = math.sqrt(e[0] * e[0] + e[1] * e[1] + (e[2] * e[2] if all_p else 0.0))
        err_o = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        track_p[k], track_o[k] = err_p, err_o
        at_end = tau >= setpoint.end - 0.5 * dt
        if at_end and err_p <= GOAL_FRACTION * goal_p and err_o <= GOAL_FRACTION * goal_o:
            n = k + 1
            break
        if k == total:
            n = k + 1
            if not (at_end and err_p <= goal_p and err_o <= goal_o):
                first = first_limit(positions[1:n], lo_q, hi_q, s_log) if dls else None
                failure = stuck(robot, line, q, sigma[k - 1], first, at_end, s, dt * k)
            break
        J = J_now if all_rows else J_now[rows]
        # V = kappa s' unit_twist + K e, element by element (as the array expression would; zip
        # without strict=True, which costs ~0.8 us a call: the lengths are equal by construction).
        e_task = e if all_rows else [e[i] for i in row_list]
        nxt = positions[k + 1]
        if dls:
            gram = J.dot(J.T)
            if wide:
                sigma_min = smallest_singular_value(J, gram, 2.0 * SINGULAR_REGION)
            else:
                sigma_min = float(singular_values(J)[-1])
            sigma[k] = sigma_min
            lam_log[k] = lam = damping(sigma_min, floor=floor)
            gains = 1.0 / sigma_min if sigma_min > 0.0 else math.inf
            if lam > 0.0:
                gains = min(gains, 0.5 / lam)
            kappa = 1.0
            if abs(sd) * gains * twist_bound > TIME_SCALE_MARGIN:  # the norm bound may bind
                twist = sd * unit_twist
                # Cholesky first: the SVD route (exactly as before) only where it may bind.
                if lam != shift_lam:  # lam^2 I, kept while lam is (the Panda's floor)
                    shift_lam, shift = lam, lam * lam * np.eye(len(rows)) if lam else None
                ratio = feedforward_ratio(J, gram, shift, twist, vmax)
                if ratio > TIME_SCALE_MARGIN * (1.0 - 1e-9):
                    scale[k] = kappa = time_scale(*svd(J), twist, lam, vmax)
            B = bounds[k]  # rate_bounds(q, limits, dt), written in place (as filled while clear)
            clear = k < clear_until
            if not clear:
                np.subtract(position_box, q, out=B)
                np.divide(B, dt, out=B)
                if k >= recheck:
                    clear_until = k + 1 + clear_ticks(B, vmax, n)
                    recheck = clear_until if clear_until > k + 1 else k + _RECHECK
                np.maximum(B, low_v, out=B)
                np.minimum(B, vmax, out=B)
            V = np.array([kappa * (sd * u) + gain * x for u, x in zip(units, e_task, strict=False)])
            start = clock()
            if qp is not None:
                its[k], fell_back, _ = qp.solve(
                    J,
                    V,
                    lam,
                    B[0],
                    B[1],
                    rates[k],
                    no_rows if extra_rows is None else extra_rows(q),
                )
                times[k] = clock() - start
            else:
                step = solve_dls_qp(build_dls_qp(J, V, lam, q, limits, dt), solver)
                rates[k], its[k], times[k], fell_back = (
                    step.x,
                    step.iterations,
                    step.solve_time,
                    step.fallback,
                )
            fallbacks += fell_back
            if capped:  # the tool's speed limits hold for the feedback term too
                c = speed_scale(J_now, rates[k], p_list, lin_cap, ang_cap)
                if c < 1.0:
                    rates[k] *= c
            np.multiply(rates[k], dt, out=nxt)
            np.add(q, nxt, out=nxt)
            if not clear:  # (a clear tick's q + qd dt is more than v_max dt inside the limits)
                np.maximum(nxt, lo_q, out=nxt)
                np.minimum(nxt, hi_q, out=nxt)
        else:
            kappa = 1.0
            U, S, Vt = svd(J)
            sigma[k] = S[-1]
            V = np.array([sd * u + gain * x for u, x in zip(units, e_task, strict=False)])
            failure, qd = pinv_step(robot, U, S, Vt, V, s, q, dt, limits)
            if failure is not None:
                n = k + 1
                break
            if capped:
                qd = qd * speed_scale(J_now, qd, p_list, lin_cap, ang_cap)
            rates[k] = qd
            np.multiply(qd, dt, out=nxt)
            np.add(q, nxt, out=nxt)
        q, tau = nxt, tau + kappa * dt
        if kappa != 1.0:  # the tabulated setpoints no longer apply
            nominal_clock, block_end, block_size = False, 0, _FIRST_BLOCK
        elif not nominal_clock:
            nominal_clock = True
    steps = n - 1
    active = np.zeros(steps, dtype=bool)
    if dls:
        R, B = rates[:steps], bounds[:steps]
        near = (R <= B[:, 0] + ACTIVE_TOLERANCE) | (R >= B[:, 1] - ACTIVE_TOLERANCE)
        active = np.asarray(near.any(axis=1))
    return RateRun(
        dt=dt,
        nominal_ticks=nominal,
        nominal_duration=float(timing.duration),
        positions=positions[:n],
        rates=rates[:n],
        s=s_log[:n],
        sigma=sigma[:steps],
        damping=lam_log[:steps],
        time_scale=scale[:steps],
        active=active,
        iterations=its[:steps],
        solve_time=times[:steps],
        fallbacks=int(fallbacks),
        tracking_position=track_p[:n],
        tracking_orientation=track_o[:n],
        failure=failure,
    )
