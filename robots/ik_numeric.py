"""Inverse kinematics solvers behind ``Robot.ik``.

- ``solve_pose``: damped Newton / Levenberg-Marquardt on the SE3 log error ``log6(T(q)^-1 T_goal)``
  (pinocchio, a fresh ``Data`` per call), with the error's Jacobian ``-Jlog6(E^-1) J_local``.
- ``solve_position_xy``: the same iteration on the x and y of the tip position only (planar arms).
- ``planar_2r``: the 2-link planar arm in closed form, both elbow branches, nearest to the seed.

All respect joint position limits by projection (revolute joints are first moved by whole turns toward
the middle of their range, then clipped), stop at an iteration cap and never raise for non-convergence:
they return an ``IKResult`` with ``success=False`` and the honest residuals.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from core.kinematics import IKResult
from robots.chain import Chain

TWO_PI = 2.0 * math.pi
LOCAL, ALIGNED = pin.LOCAL, pin.LOCAL_WORLD_ALIGNED
_MU_START, _MU_MIN, _MU_MAX = 1e-3, 1e-12, 1e6
"""Levenberg-Marquardt damping: lambda = mu * (1 + ||e||^2), mu / 10 on progress, * 10 on a rejected step."""

Residual = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, float, float]]
"""q -> (error e (m,), de/dq (m, n), position error [m], orientation error [rad])."""


def project(
    q: np.ndarray, lower: np.ndarray, upper: np.ndarray, revolute: np.ndarray
) -> np.ndarray:
    """Joint positions moved into ``[lower, upper]``: whole turns first (revolute), then clipping."""
    out = (q < lower) | (q > upper)
    if not out.any():
        return q
    q = q.copy()
    turn = out & revolute
    if turn.any():
        mid = 0.5 * (lower[turn] + upper[turn])
        q[turn] -= TWO_PI * np.round((q[turn] - mid) / TWO_PI)
    return np.clip(q, lower, upper)


def within(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    return bool(np.all(q >= lower - 1e-12) and np.all(q <= upper + 1e-12))


def levenberg_marquardt(
    residual: Residual,
    seed: np.ndarray,
    limits: tuple[np.ndarray, np.ndarray, np.ndarray],
    max_iterations: int,
    position_tolerance: float,
    orientation_tolerance: float,
    respect_limits: bool = True,
) -> IKResult:
    """Minimize ``||e(q)||^2`` from ``seed``.

    Args:
        limits: (lower, upper, revolute mask), each ``(n,)``.
        respect_limits: Project every iterate into the limits; False lets the iteration roam (used to
            tell "unreachable" from "reachable only outside the limits").
    """
    lower, upper, revolute = limits
    q = np.array(seed, dtype=float)  # never alias the caller's array
    q = project(q, lower, upper, revolute) if respect_limits else q
    e, J, pe, oe = residual(q)
    cost = float(e @ e)
    mu, it = _MU_START, 0
    eye = np.eye(len(e))
    solve = np.linalg.solve
    at_limit = respect_limits and bool(((q <= lower) | (q >= upper)).any())
    while not (pe <= position_tolerance and oe <= orientation_tolerance) and it < max_iterations:
        it += 1
        damping = (mu * (1.0 + cost)) * eye
        dq = -J.T @ solve(J @ J.T + damping, e)
        if at_limit:
            # Active set: a joint pushed past a limit it already sits on is frozen, and the step
            # is solved again with the other joints (at most a few passes).
            for _ in range(3):
                blocked = ((q <= lower) & (dq < 0)) | ((q >= upper) & (dq > 0))
                if not blocked.any():
                    break
                Jf = J * ~blocked
                dq = -Jf.T @ solve(Jf @ Jf.T + damping, e)
        q_new = q + dq
        if respect_limits and ((q_new < lower) | (q_new > upper)).any():
            q_new = project(q_new, lower, upper, revolute)
        e_new, J_new, pe_new, oe_new = residual(q_new)
        cost_new = float(e_new @ e_new)
        if cost_new < cost:
            q, e, J, pe, oe, cost = q_new, e_new, J_new, pe_new, oe_new, cost_new
            mu = max(mu * 0.1, _MU_MIN)
            at_limit = respect_limits and bool(((q <= lower) | (q >= upper)).any())
        else:
            mu *= 10.0
            if mu > _MU_MAX:
                break
    inside = within(q, lower, upper)
    converged = pe <= position_tolerance and oe <= orientation_tolerance
    return IKResult(q, bool(converged and inside), float(pe), float(oe), it, inside)


def solve_pose(
    model: pin.Model, tip_id: int, T_world_goal: pin.SE3, seed: np.ndarray, limits, **options
) -> IKResult:
    """Pose IK of frame ``tip_id`` to ``T_world_goal`` (in the model's root frame)."""
    data, n = pin.Data(model), model.nv
    goal_p = T_world_goal.translation

    def residual(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
        pin.computeJointJacobians(model, data, q)
        M = pin.updateFramePlacement(model, data, tip_id)
        E = M.actInv(T_world_goal)
        e = pin.log6(E).vector
        J = -pin.Jlog6(E.inverse()) @ pin.getFrameJacobian(model, data, tip_id, LOCAL).reshape(6, n)
        dp, w = M.translation - goal_p, e[3:]
        return e, J, math.sqrt(dp @ dp), math.sqrt(w @ w)

    return levenberg_marquardt(residual, seed, limits, **options)


def solve_position_xy(
    model: pin.Model,
    tip_id: int,
    T_base_world: np.ndarray,
    goal_xy: np.ndarray,
    seed: np.ndarray,
    limits,
    **options,
) -> IKResult:
    """IK of the tip's x and y in the base frame (z and orientation are free)."""
    data, n = pin.Data(model), model.nv
    R, t = T_base_world[:2, :3], T_base_world[:2, 3]

    def residual(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
        pin.computeJointJacobians(model, data, q)
        M = pin.updateFramePlacement(model, data, tip_id)
        J = pin.getFrameJacobian(model, data, tip_id, ALIGNED).reshape(6, n)
        e = R @ M.translation + t - goal_xy
        return e, R @ J[:3], math.sqrt(e @ e), 0.0

    return levenberg_marquardt(residual, seed, limits, **options)


def _nearest_turn(angle: float, seed: float, lower: float, upper: float) -> tuple[float, bool]:
    """``angle + 2 pi k`` nearest ``seed`` inside [lower, upper] (or nearest ``seed``, False)."""
    k_lo, k_hi = math.ceil((lower - angle) / TWO_PI), math.floor((upper - angle) / TWO_PI)
    k = round((seed - angle) / TWO_PI)
    if k_lo > k_hi:
        return angle + TWO_PI * k, False
    return angle + TWO_PI * min(max(k, k_lo), k_hi), True


def planar_2r(
    goal_xy: np.ndarray,
    seed: np.ndarray,
    l1: float,
    l2: float,
    lower: np.ndarray,
    upper: np.ndarray,
) -> tuple[np.ndarray, bool]:
    """Closed-form IK of the planar 2-link arm (link lengths ``l1``, ``l2`` [m]).

    Returns the elbow branch inside the limits nearest ``seed`` (Euclidean in joint space) and whether
    it is inside the limits. Outside the annulus |l1 - l2| <= r <= l1 + l2 it returns the arm pointing
    at the goal, stretched or folded: the nearest reachable point, so the residual tells the distance.
    """
    x, y = float(goal_xy[0]), float(goal_xy[1])
    c2 = min(1.0, max(-1.0, (x * x + y * y - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)))
    s2 = math.sqrt(max(0.0, 1.0 - c2 * c2))
    candidates = []
    for sign in (1.0, -1.0):
        q2 = math.atan2(sign * s2, c2)
        q1 = math.atan2(y, x) - math.atan2(l2 * sign * s2, l1 + l2 * c2)
        a, ok1 = _nearest_turn(q1, seed[0], lower[0], upper[0])
        b, ok2 = _nearest_turn(q2, seed[1], lower[1], upper[1])
        q = np.array([a, b])
        candidates.append((not (ok1 and ok2), float(np.linalg.norm(q - seed)), sign, q))
    outside, _, _, q = min(candidates, key=lambda c: c[:3])
    return q, not outside


def planar_2r_geometry(chain: Chain) -> tuple[np.ndarray, float, float, np.ndarray] | None:
    """A planar 2R chain about +z axes as ``planar_2r`` sees it: joint 1's origin (x, y) [m], the link
    lengths l1 (joint 1 to joint 2) and l2 (joint 2 to the chain's tip, a tool point included) [m],
    and the angles [rad] of both links at q = 0 (link 1 absolute, link 2 relative to link 1): the
    offsets between the joint positions and ``planar_2r``'s. None for other chains."""
    if len(chain.q_index) != 2 or not chain.revolute.all():
        return None
    z, o, T = chain.joint_axes_many(np.zeros((1, 2)))
    if not np.allclose(z[0], [[0.0, 0.0, 1.0]] * 2, atol=1e-12):
        return None
    o1, o2, p = o[0, 0, :2], o[0, 1, :2], T[0, :2, 3]
    first, second = o2 - o1, p - o2
    l1, l2 = float(np.hypot(*first)), float(np.hypot(*second))
    if l1 < 1e-9 or l2 < 1e-9:
        return None
    theta = math.atan2(first[1], first[0])
    return o1, l1, l2, np.array([theta, math.atan2(second[1], second[0]) - theta])


def search(
    robot, T_base_tool: np.ndarray, seed: np.ndarray | None = None, *, restarts: int = 16, **options
) -> IKResult:
    """IK from ``seed`` (default ``robot.home``), then from ``restarts`` fixed pseudo-random seeds
    inside the limits (revolute ranges capped to +-pi around 0): the first success, else the attempt
    with the smallest residual. Deterministic: the same request gets the same answer.

    ``robot`` is a ``robots.model.Robot``; ``options`` go to ``robot.ik``.
    """
    lower, upper = robot.position_limits[:, 0], robot.position_limits[:, 1]
    first = robot.home if seed is None else np.clip(np.asarray(seed, dtype=float), lower, upper)
    rng = np.random.default_rng(0)
    lo, hi = np.maximum(lower, -math.pi), np.minimum(upper, math.pi)
    lo, hi = np.where(lo <= hi, lo, lower), np.where(lo <= hi, hi, upper)
    best: IKResult | None = None
    for k in range(restarts + 1):
        start = first if k == 0 else rng.uniform(lo, hi)
        result = robot.ik(T_base_tool, start, **options)
        if result.success:
            return result
        if best is None or result.position_error + result.orientation_error < (
            best.position_error + best.orientation_error
        ):
            best = result
    return best  # type: ignore[return-value]
