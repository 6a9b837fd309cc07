"""IK along a Cartesian path given as a pose function: one branch, every step checked.

``walk(robot, poses, q0, grid)`` solves IK at the path parameters of ``grid`` (increasing, from 0),
each seeded where the Jacobian predicts the arm will be (q + J^+ dx, dx the pose step), so the arm
keeps the branch of ``q0``. A step that fails is halved down to ``MIN_STEP``; what still fails is
the failure, with its cause and path parameter s (as for a single line, ``core.cartesian``):
``unreachable`` (no IK within ``IK_TOLERANCE``), ``joint_limit``, ``branch_flip`` (a joint step far
off the prediction) or ``singularity`` (smallest singular value of the task Jacobian below
``SINGULAR_VALUE_THRESHOLD``). The walk returns the solved prefix and the failure, never raises
for one, so a caller can keep a partial plan.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.joint_limits import outside, worst_joint
from core.errors import BranchFlip, JointLimit, PlanningError, Singularity, Unreachable
from core.kinematics import Kinematics, task_rows

IK_TOLERANCE = 1e-6
"""Largest IK residual [m] and [rad] accepted as on the path."""
IK_SOLVE_TOLERANCE = 1e-9
SINGULAR_VALUE_THRESHOLD = 1e-3
MIN_STEP = 1e-5
"""Smallest step in s; a failure is located to it."""
MAX_JOINT_STEP = 0.1
"""Largest joint step [rad] predicted in one step: where joints move fast the walk steps shorter."""
BRANCH_RATIO = 0.5
BRANCH_ABS = 1e-3
_TWO_PI = 2.0 * np.pi

PoseFunction = Callable[[np.ndarray], np.ndarray]
"""Path parameters (N,) -> tool poses (N, 4, 4)."""


@dataclass(frozen=True)
class Walk:
    """IK along a path up to the first failure.

    Attributes:
        s: Path parameters solved, ``(K,)``, from 0.
        q: Joint positions there, ``(K, dof)``, on one branch.
        failure: What stopped the walk before the grid's end, else None.
        min_singular_value: Smallest singular value of the task Jacobian seen.
    """

    s: np.ndarray
    q: np.ndarray
    failure: PlanningError | None
    min_singular_value: float


def walk(
    robot: Kinematics,
    poses: PoseFunction,
    q0: np.ndarray,
    grid: np.ndarray,
    deadline: Deadline = NO_DEADLINE,
) -> Walk:
    """IK at every s of ``grid`` (and more where steps are halved), from ``q0`` at s = grid[0]."""
    rows = task_rows(robot.task_space)
    limits = robot.position_limits
    options = {"respect_limits": False}
    names = robot.joint_names

    q = np.asarray(q0, dtype=float)
    T, J = robot.fk_jacobian(q)
    sigma_min = float(np.linalg.svd(J[rows], compute_uv=False)[-1])
    s_out, q_out = [float(grid[0])], [q]
    h_max = float(np.max(np.diff(grid))) if len(grid) > 1 else 1.0
    h = h_max
    s_cur = float(grid[0])

    cached = dict(zip(np.asarray(grid, dtype=float).tolist(), poses(np.asarray(grid)), strict=True))

    def step(s_try: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | PlanningError:
        T_goal = cached.get(s_try)
        if T_goal is None:
            T_goal = poses(np.array([s_try]))[0]
        dR = T_goal[:3, :3] @ T[:3, :3].T
        # The seed only needs the first-order rotation: vee of the skew part (exact for small steps).
        w = 0.5 * np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]])
        dx = np.concatenate([T_goal[:3, 3] - T[:3, 3], w])
        dq = np.linalg.lstsq(J[rows], dx[rows], rcond=None)[0]
        pred = q + dq
        r = robot.ik(
            T_goal,
            pred,
            position_tolerance=IK_SOLVE_TOLERANCE,
            orientation_tolerance=IK_SOLVE_TOLERANCE,
            **options,
        )
        q_new = np.asarray(r.positions, dtype=float)
        if max(r.position_error, r.orientation_error) > IK_TOLERANCE:
            return Unreachable(
                f"no IK solution within {IK_TOLERANCE:g} m at s={s_try:.4f}",
                s=s_try,
                extra={"residual": max(r.position_error, r.orientation_error)},
            )
        turns = np.round((q_new - pred) / _TWO_PI)
        if turns.any():
            q_new = q_new - _TWO_PI * turns
        if np.abs(q_new - pred).max() > BRANCH_RATIO * np.abs(dq).max() + BRANCH_ABS:
            j = int(np.argmax(np.abs(q_new - pred)))
            return BranchFlip(
                f"joint {names[j]} would jump by {abs(q_new[j] - q[j]):.3g} rad at s={s_try:.4f} "
                f"where the Jacobian predicts {abs(dq[j]):.3g} rad: IK is on another branch",
                s=s_try,
                joint=j,
            )
        if outside(q_new, limits).any():
            j = worst_joint(q_new, limits)
            return JointLimit(
                f"joint {names[j]} leaves its position limits at s={s_try:.4f}", s=s_try, joint=j
            )
        T_new, J_new = robot.fk_jacobian(q_new)
        sv = float(np.linalg.svd(J_new[rows], compute_uv=False)[-1])
        if len(rows) > robot.dof or sv < SINGULAR_VALUE_THRESHOLD:
            return Singularity(
                f"the Jacobian is singular at s={s_try:.4f} (smallest singular value {sv:.3g})",
                s=s_try,
                extra={"min_singular_value": sv},
            )
        return q_new, T_new, J_new, sv

    failure: PlanningError | None = None
    for target in grid[1:]:
        while failure is None and s_cur < target:
            deadline.check("IK along the program's path")
            if len(q_out) > 1:
                rate = np.abs(q_out[-1] - q_out[-2]).max() / max(s_out[-1] - s_out[-2], 1e-15)
                if rate * h > MAX_JOINT_STEP:
                    h = max(MAX_JOINT_STEP / rate, MIN_STEP)
            s_try = float(target) if target - (s_cur + h) < 0.5 * MIN_STEP else s_cur + h
            out = step(s_try)
            if isinstance(out, PlanningError):
                if s_try - s_cur <= MIN_STEP:
                    failure = out
                    if isinstance(out, Singularity) and _beyond_reach(robot, poses, q, s_try):
                        failure = Unreachable(
                            f"no IK solution at s={s_try:.4f}: the path leaves the workspace "
                            "there (the arm is singular at its edge)",
                            s=s_try,
                        )
                h = 0.5 * (s_try - s_cur)
                continue
            q, T, J, sv = out
            sigma_min = min(sigma_min, sv)
            s_out.append(s_try)
            q_out.append(q)
            s_cur, h = s_try, min(2.0 * h, h_max)
        if failure is not None:
            break
    return Walk(np.array(s_out), np.array(q_out), failure, sigma_min)


EDGE_PROBE = 1e-3
"""How far past a singular point [in s] IK is tried to tell the workspace's edge (Type I)."""


def _beyond_reach(robot: Kinematics, poses: PoseFunction, q: np.ndarray, s: float) -> bool:
    """Whether the path is out of reach ``EDGE_PROBE`` past ``s`` (no IK from ``q`` or from seeds
    spread over the joint space): a singular point there is the workspace's edge."""
    T = poses(np.array([min(s + EDGE_PROBE, 1.0)]))[0]
    lo = np.maximum(robot.position_limits[:, 0], -np.pi)
    hi = np.minimum(robot.position_limits[:, 1], np.pi)
    seeds = [q, *np.random.default_rng(0).uniform(lo, hi, (8, len(q)))]
    for seed in seeds:
        r = robot.ik(T, seed)
        if max(r.position_error, r.orientation_error) <= IK_TOLERANCE:
            return False
    return True
