"""Branch-following IK along the line for the knot methods: one point on the start's branch
(``solve_on_line``), the continuation along the whole line (``continuation``), and the goal's
configuration on the start's branch (``goal_configuration``).
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.knot_path import Knots
from core.errors import (
    BranchFlip,
    JointLimit,
    Unreachable,
)
from core.geometry import so3
from core.kinematics import Kinematics, task_rows
from core.path.line import StraightLine

BRANCH_FACTOR = 3.0
"""A knot IK solution may be at most this many times farther (max-abs, per joint) from its seed than
the Jacobian's least-squares step predicts, plus ``BRANCH_SLACK``; farther is another branch."""
BRANCH_SLACK = 0.05
"""[rad or m] absolute slack of the branch test."""
IK_TOLERANCE = 1e-6
"""Largest IK residual [m] and [rad] of a knot accepted as on the line."""


GOAL_BRANCH_TOLERANCE = 0.1
"""[rad] a requested goal configuration is used when it is this close (max-abs) to the one reached by
IK continuation along the line from the start, i.e. on the same branch."""
CONTINUATION_STEP = (0.05, 0.25)
"""Largest step [m], [rad] of tool motion of the IK continuation that finds the goal configuration
on the start's branch."""
CONTINUATION_JOINT_STEP = 0.1
"""Largest predicted joint step [rad] of one continuation step."""
MIN_CONTINUATION_STEP = 1e-5
"""Shortest continuation step [share of s]; a failure there is the line's failure."""
STRICT_BRANCH = (0.5, 1e-3)
"""Continuation steps: the IK solution must be within ``0.5 |predicted step| + 1e-3`` [rad]
(max-abs) of where the Jacobian predicts (the test of the ``sampled`` method)."""


def task_error(task_space: str, T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    """Position [m] and orientation [rad] difference of two poses (4, 4), task components only."""
    rows = 2 if task_space == "position_xy" else 3
    position = float(np.linalg.norm(T_a[:rows, 3] - T_b[:rows, 3]))
    if task_space == "position_xy":
        return position, 0.0
    return position, float(so3.rotation_angle(T_a[:3, :3].T @ T_b[:3, :3]))


def predicted_step(kin: Kinematics, q: np.ndarray, T_target: np.ndarray) -> np.ndarray:
    """Least-squares joint step (dof,) the Jacobian at ``q`` predicts toward the pose ``T_target``."""
    T = kin.fk(q)
    twist = np.zeros(6)
    twist[:3] = T_target[:3, 3] - T[:3, 3]
    twist[3:] = so3.log(T_target[:3, :3] @ T[:3, :3].T)
    rows = task_rows(kin.task_space)
    step, *_ = np.linalg.lstsq(kin.jacobian(q)[rows], twist[rows], rcond=1e-6)
    return step


def same_branch(step: np.ndarray, predicted: np.ndarray) -> bool:
    """Whether a joint ``step`` (dof,) is within what the Jacobian's ``predicted`` step allows."""
    limit = BRANCH_FACTOR * float(np.max(np.abs(predicted))) + BRANCH_SLACK
    return float(np.max(np.abs(step))) <= limit


def solve_on_line(
    kin: Kinematics,
    line: StraightLine,
    s: float,
    seed: np.ndarray,
    reference: np.ndarray | None = None,
    *,
    strict: bool = False,
) -> np.ndarray:
    """Joint positions (dof,) at the line's pose at ``s``, on the branch of ``seed``.

    IK from ``seed``, then from the seed moved by the Jacobian's predicted step, then from
    ``reference`` (a configuration on the start's branch near ``s``, from ``continuation``). A
    solution is on the branch when its distance to the seed, or to the reference, is within what the
    Jacobian predicts (``same_branch``); ``strict`` (small steps): when it is within
    ``STRICT_BRANCH`` of the predicted configuration. Raises ``BranchFlip`` when IK converges only on
    another branch, ``JointLimit`` when only outside the joint limits, ``Unreachable`` when not at
    all; each with ``s``.
    """
    T = line.pose(s)
    seed = np.asarray(seed, dtype=float)
    anchors = [(seed, predicted_step(kin, seed, T))]
    starts = [seed + anchors[0][1], seed] if strict else [seed, seed + anchors[0][1]]
    if reference is not None:
        anchors.append((reference, predicted_step(kin, reference, T)))
        starts.append(reference)
    outcome = "unreachable"
    # IK roams outside the limits, so a solution reachable only outside them is told apart
    # (joint_limit) from no solution at all (unreachable).
    for start in starts:
        res = kin.ik(
            T, start, position_tolerance=1e-9, orientation_tolerance=1e-9, respect_limits=False
        )
        converged = res.position_error <= IK_TOLERANCE and res.orientation_error <= IK_TOLERANCE
        if not converged:
            continue
        if not res.within_limits:
            outcome = "joint_limit" if outcome == "unreachable" else outcome
            continue
        q = np.asarray(res.positions, dtype=float)
        if strict:
            predicted = anchors[0][1]
            off = float(np.max(np.abs(q - seed - predicted)))
            if off <= STRICT_BRANCH[0] * float(np.max(np.abs(predicted))) + STRICT_BRANCH[1]:
                return q
        elif any(same_branch(q - anchor, predicted) for anchor, predicted in anchors):
            return q
        outcome = "branch_flip"
    where = f"at s={s:.4g}"
    if outcome == "branch_flip":
        raise BranchFlip(f"IK on the line {where} lands only on another branch", s=float(s))
    if outcome == "joint_limit":
        raise JointLimit(f"the line {where} is reachable only outside the joint limits", s=float(s))
    raise Unreachable(f"no IK solution within {IK_TOLERANCE:g} m on the line {where}", s=float(s))


def continuation(
    kin: Kinematics, line: StraightLine, q_start: np.ndarray, deadline: Deadline = NO_DEADLINE
) -> Knots:
    """IK along the line from ``q_start``, each point seeded where the Jacobian predicts the arm
    will be and checked to be there (``strict`` branch test): the start's branch.

    Steps of at most ``CONTINUATION_STEP`` of tool motion, 1/256 of the line, and
    ``CONTINUATION_JOINT_STEP`` of predicted joint motion (short steps where joints move fast, near
    singularities), halved down to ``MIN_CONTINUATION_STEP`` where a step fails; the failure there is
    raised with ``extra["s_reached"]``.
    """
    steps = int(np.ceil(max(line.length / CONTINUATION_STEP[0], line.angle / CONTINUATION_STEP[1])))
    ds_max = 1.0 / min(max(steps, 1), 256)
    rows = task_rows(kin.task_space)
    twist = line.derivative(np.zeros(1))[0][rows]  # tool twist per unit s (a line: constant)
    s, q = 0.0, np.asarray(q_start, dtype=float)
    s_list, q_list = [s], [q]
    halved = 1.0
    while s < 1.0:
        deadline.check("bounded deviation: IK continuation")
        dq_ds, *_ = np.linalg.lstsq(kin.jacobian(q)[rows], twist, rcond=1e-6)
        rate = float(np.max(np.abs(dq_ds)))
        ds = min(ds_max, CONTINUATION_JOINT_STEP / rate if rate > 0 else ds_max) * halved
        ds = max(ds, MIN_CONTINUATION_STEP)
        s_next = min(1.0, s + ds)
        try:
            q = solve_on_line(kin, line, s_next, q, strict=True)
        except (BranchFlip, Unreachable, JointLimit) as err:
            if ds <= MIN_CONTINUATION_STEP:
                err.extra["s_reached"] = s
                raise
            halved *= 0.5
            continue
        s, halved = s_next, min(1.0, 2.0 * halved)
        s_list.append(s)
        q_list.append(q)
    return Knots(np.array(s_list), np.array(q_list))


def reference_at(reference: Knots | None, s: float) -> np.ndarray | None:
    """The continuation's configuration at ``s`` (linear between its points), or None."""
    if reference is None:
        return None
    return np.array([np.interp(s, reference.s, col) for col in reference.positions.T])


def goal_configuration(
    kin: Kinematics,
    line: StraightLine,
    q_start: np.ndarray,
    q_hint: np.ndarray | None = None,
    deadline: Deadline = NO_DEADLINE,
) -> tuple[np.ndarray, list[str], Knots]:
    """The goal's joint positions on the start's branch, warnings, and the continuation.

    The end of ``continuation``; ``q_hint`` (the request's goal positions) is used instead when it
    lies within ``GOAL_BRANCH_TOLERANCE`` of it, otherwise a warning says so.
    """
    reference = continuation(kin, line, q_start, deadline)
    q = reference.positions[-1]
    if q_hint is not None:
        q_hint = np.asarray(q_hint, dtype=float)
        gap = float(np.max(np.abs(q_hint - q)))
        if gap <= GOAL_BRANCH_TOLERANCE:
            return q_hint, [], reference
        return (
            q,
            [
                f"the line ends at the goal pose in another joint configuration than goal.positions "
                f"(up to {gap:.3g} rad apart): the trajectory ends where the line leads, without a "
                "branch flip"
            ],
            reference,
        )
    return q, [], reference
