"""Resolved-rate control along the straight line: pseudo-inverse (``resolved_rate``) and damped
least squares as a QP (``resolved_rate_dls``), simulated tick by tick.

The nominal duration T is split into whole ticks of ``dt = T / ceil(T / control_period)`` (so
``dt <= control_period`` and the nominal end falls on a tick). At each tick:

1. The setpoint: pose on the path at ``s(tau)`` and twist ``path.derivative(s) s'(tau)``, where ``s(t)`` is
   the nominal profile every Cartesian method starts from (quintic for a fixed duration, else the
   speed-limited trapezoid of ``CartesianTask.speeds()``) without joint-rate caps (meeting the joint
   limits is the controller's business) and ``tau`` is the path clock (below).
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
     It refuses to step where the smallest singular value is below ``PINV_SINGULAR_THRESHOLD``
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
from dataclasses import dataclass

import numpy as np

from core.cartesian.joint_limits import outside, over_speed
from core.cartesian.rate.qp import (
    REDUNDANCY_DAMPING,
    SINGULAR_REGION,
    DlsQpSolver,
    RateLimits,
    build_dls_qp,
    check_solver,
    damping,
    rate_bounds,
    solve_dls_qp,
)
from core.cartesian.task import CartesianTask
from core.cartesian.timing import nominal_profile
from core.cartesian.validate import validated_line
from core.errors import (
    InputError,
    JointLimit,
    JointRateLimit,
    NoConvergence,
    PlanningError,
    Singularity,
    TooLarge,
)
from core.geometry import so3
from core.kinematics import task_rows
from core.path import Path
from core.timing import Profile

FEEDBACK_GAIN = 20.0
"""K [1/s]: pose-error feedback gain (error time constant 50 ms)."""
MAX_GAIN_PER_TICK = 0.5
"""Upper bound on ``K dt``."""
PINV_SINGULAR_THRESHOLD = 1e-3
"""``resolved_rate`` refuses to step below this smallest singular value (J^+ would amplify 1000x)."""
GOAL_FRACTION = 0.1
"""The run ends once the pose error is within this share of the position and orientation tolerance."""
SETTLE_TIME = 1.0
"""[s] Least time allowed after the nominal duration to reach the goal."""
SETTLE_FRACTION = 1.0
"""Time allowed after the nominal duration, as a share of it (when longer than ``SETTLE_TIME``)."""
MAX_TICKS = 1_000_000
"""Most control ticks one run may simulate (bounds memory and time; ``TooLarge`` beyond)."""
ACTIVE_TOLERANCE = 1e-6
"""[rad/s] A rate this close to its bound counts as an active limit."""
TIME_SCALE_MARGIN = 0.95
"""The path clock slows so the feedforward rates use at most this share of the velocity limits,
leaving the rest to the feedback term."""
_CHECK_EVERY = 256
_SETPOINT_BLOCK = 256
"""Setpoint poses evaluated per vectorized ``Path.poses`` call."""
_ON_TICK = 1e-9
"""A clock time within this share of a tick of it is that tick (rounding of the summed steps)."""
RATE_METHODS = ("resolved_rate", "resolved_rate_dls")


@dataclass(frozen=True)
class RateRun:
    """The simulated control ticks of one run (n ticks, ``k = 0..n-1``; steps ``k = 0..n-2``).

    Attributes:
        dt: Control period [s].
        nominal_ticks: Ticks in the nominal duration.
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
    """

    dt: float
    nominal_ticks: int
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


def nominal_timing(task: CartesianTask, line: Path) -> Profile:
    """s(t): quintic for ``task.duration``, else the speed-limited profile of ``task.speeds()``
    (the S-curve for ``speed_profile="s_curve"``: ``core.cartesian.timing.nominal_profile``)."""
    return nominal_profile(task, line)


class _Setpoint:
    """Pose, unit twist and s on the path at path-clock time tau (s(t) tabulated per tick).

    At a tick of the grid (the clock runs at full rate) the pose and d(pose)/ds come from a table
    evaluated ``_SETPOINT_BLOCK`` ticks at a time (one vectorized ``Path.poses`` call per block);
    between ticks (a time-scaled clock) from ``Path.pose`` at that s. Both are exact."""

    def __init__(self, line: Path, timing: Profile, dt: float, n: int):
        grid = np.arange(n + 2) * dt
        self.s, self.sd, self.dt, self.end = timing(grid), timing(grid, 1), dt, n * dt
        self.line = line
        self._block, self._poses, self._rates = -1, np.zeros((0, 4, 4)), np.zeros((0, 6))

    def _at_tick(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        block, row = divmod(k, _SETPOINT_BLOCK)
        if block != self._block:
            s = self.s[block * _SETPOINT_BLOCK : (block + 1) * _SETPOINT_BLOCK]
            self._block, self._poses = block, self.line.poses(s)
            self._rates = self.line.derivative(s)
        return self._poses[row], self._rates[row]

    def __call__(self, tau: float) -> tuple[float, float, np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s' [1/s], p_d (3,), R_d (3, 3), d(pose)/ds (6,))`` at clock time ``tau`` [s]
        (held after the end)."""
        x = min(tau, self.end) / self.dt
        k = round(x)
        if abs(x - k) <= _ON_TICK:
            k = min(k, len(self.s) - 1)
            T_d, rate = self._at_tick(k)
            return float(self.s[k]), float(self.sd[k]), T_d[:3, 3], T_d[:3, :3], rate
        i = min(int(x), len(self.s) - 2)
        w = x - i
        s = float((1.0 - w) * self.s[i] + w * self.s[i + 1])
        sd = float((1.0 - w) * self.sd[i] + w * self.sd[i + 1])
        T_d = self.line.pose(s)
        return s, sd, T_d[:3, 3], T_d[:3, :3], self.line.derivative(np.array([s]))[0]


def simulate(task: CartesianTask, method: str) -> RateRun:
    """Run the controller of ``method`` along the task's line (see the module docstring).

    Planning failures end the run and are returned in ``failure``; malformed input
    (``InputError``), a run over ``MAX_TICKS`` (``TooLarge``) and the deadline raise.
    """
    if method not in RATE_METHODS:
        raise InputError(f"method must be one of {', '.join(RATE_METHODS)}", field=("method",))
    robot, dls = task.robot, method == "resolved_rate_dls"
    period = float(task.control_period)
    if not math.isfinite(period) or period <= 0.0:
        raise InputError("control_period must be a finite number > 0 s", field=("control_period",))
    limits = RateLimits.of(robot)
    lo_q, hi_q, vmax = limits.position[:, 0], limits.position[:, 1], limits.velocity
    q = np.array(task.q_start, dtype=float)
    solver = check_solver(task.solver) if dls else ""
    line = validated_line(task)
    timing = nominal_timing(task, line)
    nominal = max(1, math.ceil(timing.duration / period - 1e-9))
    dt = timing.duration / nominal
    total = nominal + math.ceil(max(SETTLE_TIME, SETTLE_FRACTION * timing.duration) / dt)
    if total > MAX_TICKS:
        raise TooLarge(
            f"{total} control ticks exceed the limit of {MAX_TICKS}; raise control_period",
            field=("control_period",),
        )
    setpoint = _Setpoint(line, timing, dt, nominal)
    rows, pose_task = task_rows(robot.task_space), robot.task_space == "pose"
    p_rows = rows[rows < 3]
    gain = min(FEEDBACK_GAIN, MAX_GAIN_PER_TICK / dt)
    goal_p, goal_o = task.position_tolerance, task.orientation_tolerance
    qp = DlsQpSolver(robot.dof) if dls and solver == "osqp" else None
    floor = REDUNDANCY_DAMPING if robot.dof > len(rows) else 0.0

    n, dof = total + 1, robot.dof
    positions, rates, track = np.zeros((n, dof)), np.zeros((n, dof)), np.zeros((n, 2))
    s_log, sigma, lam, scale = np.zeros(n), np.zeros(n), np.zeros(n), np.ones(n)
    its, times, active = np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros(n, dtype=bool)
    fallbacks, failure, first_limit, tau = 0, None, None, 0.0
    e_o = np.zeros(3)
    kinematics = robot.fk_jacobian_loop()  # one scratch space for the run (this thread only)
    for k in range(n):
        if k % _CHECK_EVERY == 0:
            task.deadline.check("resolved-rate control")
        s, sd, p_d, R_d, unit_twist = setpoint(tau)
        T_now, J_now = kinematics(q)
        e_p = p_d - T_now[:3, 3]
        if pose_task:
            e_o = so3.log(R_d @ T_now[:3, :3].T)
        positions[k], s_log[k] = q, s
        err_p, err_o = math.sqrt(e_p[p_rows] @ e_p[p_rows]), math.sqrt(e_o @ e_o)
        track[k] = err_p, err_o
        at_end = tau >= setpoint.end - 0.5 * dt
        if at_end and err_p <= GOAL_FRACTION * goal_p and err_o <= GOAL_FRACTION * goal_o:
            n = k + 1
            break
        if k == total:
            n = k + 1
            if not (at_end and err_p <= goal_p and err_o <= goal_o):
                failure = _stuck(robot, line, q, sigma[k - 1], first_limit, at_end, s, dt * k)
            break
        J = J_now[rows]
        twist = sd * unit_twist[rows]  # unit_twist: per unit s' [1/s]
        feedback = gain * np.concatenate([e_p, e_o])[rows]
        U, S, Vt = np.linalg.svd(J, full_matrices=False)
        sigma[k] = S[-1]
        if dls:
            lam[k] = damping(sigma[k], floor=floor)
            scale[k] = _time_scale(U, S, Vt, twist, lam[k], vmax)
            lower, upper = rate_bounds(q, limits, dt)
            V = scale[k] * twist + feedback
            step = (
                qp.step(J, V, lam[k], lower, upper)
                if qp is not None
                else solve_dls_qp(build_dls_qp(J, V, lam[k], q, limits, dt), solver)
            )
            qd, its[k], times[k] = step.x, step.iterations, step.solve_time
            fallbacks += step.fallback
            active[k] = ((qd <= lower + ACTIVE_TOLERANCE) | (qd >= upper - ACTIVE_TOLERANCE)).any()
            q_next = np.minimum(np.maximum(q + qd * dt, lo_q), hi_q)
            pinned = (q_next <= lo_q) | (q_next >= hi_q)
            if first_limit is None and pinned.any():
                first_limit = (s, int(np.argmax(pinned)))
        else:
            failure, qd = _pinv_step(robot, U, S, Vt, twist + feedback, s, q, dt, limits)
            if failure is not None:
                n = k + 1
                break
            q_next = q + qd * dt
        rates[k], q, tau = qd, q_next, tau + scale[k] * dt
    steps = n - 1
    return RateRun(
        dt=dt,
        nominal_ticks=nominal,
        positions=positions[:n],
        rates=np.vstack([rates[:steps], np.zeros((1, dof))]),
        s=s_log[:n],
        sigma=sigma[:steps],
        damping=lam[:steps],
        time_scale=scale[:steps],
        active=active[:steps],
        iterations=its[:steps],
        solve_time=times[:steps],
        fallbacks=int(fallbacks),
        tracking_position=track[:n, 0],
        tracking_orientation=track[:n, 1],
        failure=failure,
    )


def _time_scale(U, S, Vt, twist: np.ndarray, lam: float, vmax: np.ndarray) -> float:
    """Path-clock rate in (0, 1] that keeps the DLS rates ``V diag(S / (S^2 + lam^2)) U^T twist``
    of the feedforward twist within ``TIME_SCALE_MARGIN`` of the velocity limits (1 when they
    already are); ``U, S, Vt`` is the thin SVD of the task Jacobian."""
    qd = Vt.T @ (S / (S * S + lam * lam) * (U.T @ twist))
    ratio = float(np.max(np.abs(qd) / vmax))
    return 1.0 if ratio <= TIME_SCALE_MARGIN else TIME_SCALE_MARGIN / ratio


def _pinv_step(robot, U, S, Vt, V, s, q, dt, limits):
    """The ``resolved_rate`` step ``J^+ V`` (``J^-1 V`` when square) from the thin SVD of ``J``:
    ``(failure, qd)`` with exactly one of them set."""
    sigma, vmax = float(S[-1]), limits.velocity
    if sigma < PINV_SINGULAR_THRESHOLD:
        detail = f"the Jacobian is singular (smallest singular value {sigma:.2e}) at s={s:.4f}"
        return Singularity(detail, s=s, extra={"min_singular_value": sigma}), None
    qd = Vt.T @ ((U.T @ V) / S)
    fast = np.flatnonzero(over_speed(qd, vmax))
    if fast.size:
        j = int(fast[np.argmax(np.abs(qd[fast]) / vmax[fast])])
        detail = (
            f"joint {robot.joint_names[j]} would need {abs(qd[j]):.3g} rad/s (limit "
            f"{vmax[j]:.3g}) at s={s:.4f}; the pseudo-inverse does not slow down (the DLS does)"
        )
        return JointRateLimit(detail, joint=j, s=s, extra={"rate": float(abs(qd[j]))}), None
    q_next = q + qd * dt
    out = np.flatnonzero(outside(q_next, limits.position))
    if out.size:
        j = int(out[0])
        detail = f"joint {robot.joint_names[j]} reaches its limit at s={s:.4f}"
        return JointLimit(detail, joint=j, s=s), None
    return None, qd


def _stuck(robot, line, q, sigma, first_limit, at_end, s, elapsed) -> PlanningError:
    """Why a DLS run ended short of the goal: a pinned joint, the velocity limits (the path clock
    did not reach the end), damping, or plain non-convergence."""
    s_reached = float(line.deviation(robot.fk(q)[None]).s[0])
    if first_limit is not None:
        s_hit, j = first_limit
        lo, hi = robot.position_limits[j]
        if q[j] <= lo or q[j] >= hi:
            detail = (
                f"joint {robot.joint_names[j]} is held at its position limit (reached at "
                f"s={s_hit:.4f}); the tool cannot follow the line past s={s_reached:.4f}"
            )
            return JointLimit(detail, joint=j, s=s_hit)
    if not at_end:
        detail = (
            f"the joint velocity limits slowed the line so much that after {elapsed:.3f} s it was "
            f"only at s={s:.4f}; ask for a longer duration or lower tool speeds"
        )
        return JointRateLimit(detail, s=s)
    if sigma < SINGULAR_REGION:
        detail = (
            f"the arm is stuck at a singular configuration (smallest singular value {sigma:.2e}) "
            f"at s={s_reached:.4f}: a singularity or the edge of the workspace"
        )
        return Singularity(detail, s=s_reached, extra={"min_singular_value": float(sigma)})
    return NoConvergence(
        f"the controller did not reach the goal; it stopped at s={s_reached:.4f}", s=s_reached
    )
