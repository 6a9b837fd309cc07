"""The pieces of a resolved-rate tick around the QP (``core.cartesian.rate.control`` runs them):
singular values by LAPACK without numpy's per-call wrapper, the span of ticks no position limit can
reach, the path-clock rate, the pseudo-inverse step, and why a run stopped."""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dgesdd, dposv, dsyev

from core.cartesian.rate.qp import SINGULAR_REGION
from core.errors import JointLimit, JointRateLimit, NoConvergence, PlanningError, Singularity
from core.geometry import so3
from core.geometry.so3 import SCALAR_LOG_MAX_ANGLE, SMALL_ANGLE
from core.kinematics import SINGULAR_VALUE_THRESHOLD
from core.limits import outside, over_speed

"""``resolved_rate`` refuses to step below this smallest singular value (J^+ would amplify 1000x)."""
STUCK_STRIDE = 10
"""Ticks between the positions ``stuck`` reads for the furthest point the tool reached."""
TIME_SCALE_MARGIN = 0.95
"""The path clock slows so the feedforward rates use at most this share of the velocity limits,
leaving the rest to the feedback term."""


def svd(J: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Thin SVD ``(U, S, Vt)`` of ``J`` by LAPACK's gesdd, as ``np.linalg.svd`` computes it (the
    same routine, without numpy's per-call wrapper: 9 against 17 us for 6x6); numpy's raises
    where gesdd does not converge."""
    U, S, Vt, info = dgesdd(J, full_matrices=0)
    if info != 0:
        return np.linalg.svd(J, full_matrices=False)
    return U, S, Vt


def singular_values(J: np.ndarray) -> np.ndarray:
    """Singular values of ``J`` by gesdd without the vectors (6 against 11 us for 6x7)."""
    _, S, _, info = dgesdd(J, compute_uv=0)
    return np.linalg.svd(J, compute_uv=False) if info != 0 else S


def smallest_singular_value(J: np.ndarray, gram: np.ndarray, exact_below: float) -> float:
    """The smallest singular value of a wide or square ``J`` (m, n), m <= n, from the smallest
    eigenvalue of its Gram matrix ``gram = J J^T`` (m, m) by LAPACK's syev (1.7 against 2.7 us
    for the gesdd route on 6x7; the Gram matrix is the feed-forward ratio's too), and by gesdd
    (``singular_values``) below ``exact_below``.

    An eigenvalue of the Gram matrix is off by about ``eps ||J||^2`` (rounding in the product and
    in syev), so the root is off by ``eps ||J||^2 / (2 sigma)``: relative 1e-13 at ``sigma = 0.1``
    for ``||J|| = 1.5``, but no digit at all near a singularity, where gesdd keeps its relative
    accuracy of the singular values; hence ``exact_below`` (twice ``SINGULAR_REGION`` in the
    controller, so the damping always sees gesdd's value).
    """
    mu, _, info = dsyev(gram, compute_v=0)
    if info != 0 or not mu[0] >= exact_below * exact_below:
        return float(singular_values(J)[-1])
    return math.sqrt(mu[0])


def pose_error(p: list[float], p_d: list[float], M: list[list[float]] | None) -> list[float]:
    """``[p_d - p, log(M)]`` (6 floats) for the tool position ``p`` (3), the setpoint ``p_d`` (3)
    and the orientation error ``M = R_d R^T`` (3x3 nested lists; None: no rotation part, zeros).

    ``so3.log``'s scalar route in Python floats (the same operations in the same order, so the
    same bits: a few us less per tick than numpy on a 3x3 array); ``so3.log`` itself beyond
    ``SCALAR_LOG_MAX_ANGLE``.
    """
    e = [p_d[0] - p[0], p_d[1] - p[1], p_d[2] - p[2], 0.0, 0.0, 0.0]
    if M is None:
        return e
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = M
    w0, w1, w2 = m21 - m12, m02 - m20, m10 - m01  # 2 sin(angle) axis
    sin = 0.5 * math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    angle = math.atan2(sin, 0.5 * (m00 + m11 + m22 - 1.0))
    if angle < SMALL_ANGLE:
        f = 0.5 * (1.0 + angle * angle / 6.0 + 7.0 * angle**4 / 360.0)
    elif angle <= SCALAR_LOG_MAX_ANGLE:
        f = 0.5 * angle / sin
    else:
        e[3:] = so3.log(np.array(M)).tolist()
        return e
    e[3], e[4], e[5] = f * w0, f * w1, f * w2
    return e


def first_limit(
    after: np.ndarray, lo_q: np.ndarray, hi_q: np.ndarray, s_log: np.ndarray
) -> tuple[float, int] | None:
    """``(s, joint)`` of the first step whose next positions ``after[k]`` (positions[k + 1]) put
    a joint at its position limit, or None."""
    pinned = (after <= lo_q) | (after >= hi_q)
    hits = np.flatnonzero(pinned.any(axis=1))
    if not hits.size:
        return None
    k = int(hits[0])
    return float(s_log[k]), int(np.argmax(pinned[k]))


def clear_ticks(raw: np.ndarray, vmax: np.ndarray, most: int) -> int:
    """How many ticks after this one (at most ``most``) have rate bounds equal to the velocity
    limits ``(-v_max, v_max)`` and next positions ``q + qd dt`` inside the position limits, from
    this tick's position terms ``raw = ((q_min - q)/dt, (q_max - q)/dt)`` (2, dof) of the bounds.

    Each joint has ``r = min(-raw_0, raw_1)/v_max`` ticks at full speed to its nearer limit, and
    moves at most ``v_max dt`` a tick (its rates lie within its bounds). So for the next ``i <= r -
    2`` ticks it keeps more than one tick at full speed from both limits (with a tick to spare for
    rounding): its position terms lie beyond ``-v_max`` and ``v_max``, which the bounds then are,
    and a step cannot reach a limit. 0 where any joint is closer than 3 ticks (or ``raw`` is NaN).
    """
    reach = float((np.minimum(np.negative(raw[0]), raw[1]) / vmax).min())
    return int(min(reach - 2.0, most)) if reach > 2.0 else 0


def feedforward_ratio(
    J: np.ndarray, gram: np.ndarray, shift: np.ndarray | None, twist: np.ndarray, vmax: np.ndarray
) -> float:
    """``max_j |qd_j| / v_max_j`` of the DLS rates ``qd = J^T (J J^T + lam^2 I)^-1 twist`` of the
    feedforward twist: the quantity ``time_scale`` bounds, by a Cholesky solve (2.5 against 10 us
    for the SVD route on the Panda; equal to ~1e-14 relative away from singularities, where
    ``lam = 0`` needs ``sigma_min >= SINGULAR_REGION``); inf when the solve fails.

    Args:
        J: Task Jacobian (m, n).
        gram: ``J J^T`` (m, m).
        shift: ``lam^2 I`` (m, m), or None for ``lam = 0``.
        twist: Feedforward twist (m,).
        vmax: Velocity limits (n,), > 0.
    """
    _, x, info = dposv(gram if shift is None else gram + shift, twist)
    if info != 0:
        return math.inf
    return max(map(abs, (J.T.dot(x) / vmax).tolist()))  # (Python's max: 0.6 against 1.2 us)


def time_scale(U, S, Vt, twist: np.ndarray, lam: float, vmax: np.ndarray) -> float:
    """Path-clock rate in (0, 1] that keeps the DLS rates ``V diag(S / (S^2 + lam^2)) U^T twist``
    of the feedforward twist within ``TIME_SCALE_MARGIN`` of the velocity limits (1 when they
    already are); ``U, S, Vt`` is the thin SVD of the task Jacobian."""
    qd = Vt.T.dot(S / (S * S + lam * lam) * U.T.dot(twist))  # (dot: the BLAS call of @, faster)
    ratio = float((np.abs(qd) / vmax).max())
    return 1.0 if ratio <= TIME_SCALE_MARGIN else TIME_SCALE_MARGIN / ratio


def pinv_step(robot, U, S, Vt, V, s, q, dt, limits):
    """The ``resolved_rate`` step ``J^+ V`` (``J^-1 V`` when square) from the thin SVD of ``J``:
    ``(failure, qd)`` with exactly one of them set."""
    sigma, vmax = float(S[-1]), limits.velocity
    if sigma < SINGULAR_VALUE_THRESHOLD:
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


def stuck(
    robot, line, q, sigma, first_limit, at_end, s, elapsed, held=None, path=None
) -> PlanningError:
    """Why a DLS run ended short of the goal: a pinned joint (at or beyond ``held`` ``(2, dof)``,
    default the position limits), the velocity limits (the path clock did not reach the end),
    damping, or plain non-convergence. The tool "stopped at" the furthest line parameter it
    reached over ``path`` (the run's positions, every ``STUCK_STRIDE``-th; default ``q`` alone): a
    run that hovers about a singularity at the rim ends anywhere in its swing."""
    qs = q[None] if path is None else np.vstack([path[::STUCK_STRIDE], q[None]])
    s_reached = float(line.deviation(robot.fk_many(qs)).s.max())
    if first_limit is not None:
        s_hit, j = first_limit
        lo, hi = robot.position_limits[j] if held is None else held[:, j]
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


def speed_scale(
    J: np.ndarray, qd: np.ndarray, linear_rows: int, linear: float, angular: float
) -> float:
    """Factor in (0, 1] that keeps the tool's speeds within the task's limits: the linear speed
    ``|J_p qd|`` (the Jacobian's first ``linear_rows`` rows: 3, or 2 for ``position_xy``) within
    ``linear`` [m/s] and the angular speed ``|J_w qd|`` (rows 3-5) within ``angular`` [rad/s]
    (``inf``: no limit). Scaling the rates by it keeps them inside their bounds (which contain 0)
    and the extra rows ``a . qd >= b`` (``b <= 0``). (One product and Python floats: ~1 us.)"""
    t = J.dot(qd).tolist()
    speed = math.sqrt(sum(x * x for x in t[:linear_rows]))
    scale = linear / speed if speed > linear else 1.0
    if angular < math.inf:
        turn = math.sqrt(t[3] * t[3] + t[4] * t[4] + t[5] * t[5])
        if turn * scale > angular:
            scale = angular / turn
    return scale
