"""The goals of a collision-free motion: given joints, or every IK solution of a goal pose.

A goal pose gives every IK solution within the joint limits (``Kinematics.ik_all``), only those
with the ``configuration`` label when one is asked for, nearest the start first (joint-space
distance). A redundant arm (a Panda's 7th joint) holds its ``redundant_joints`` at the start's
values; when the pose has no solution so, they are held at ``REDUNDANT_VALUES`` values spread over
their limits instead, so that a pose reachable only with the extra joint elsewhere is found (each
held value whose closed form has no solution inside the limits costs a numeric search: about 0.1 s
on a Panda, so the sweep is the fallback, not the rule). The planner then keeps the clear ones
(``clear_goals``); when none is clear the answer is ``Unreachable`` naming each solution's label
and the pair it collides with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.errors import InputError, Unreachable
from core.kinematics import Kinematics
from core.motion.clearance import GroupClearance

REDUNDANT_VALUES = 12
"""Values of each redundant joint, spread evenly strictly inside its limits, at which a goal pose's
IK solutions are gathered when it has none with the start's own value."""


@dataclass(frozen=True)
class Goals:
    """Candidate goal configurations in order of preference.

    Attributes:
        positions: ``(k, dof)`` [rad or m].
        labels: One configuration label per candidate (None for robots without labels).
        from_pose: True when they are IK solutions of a pose (a colliding goal is then
            ``Unreachable`` rather than ``Collision``).
    """

    positions: np.ndarray
    labels: tuple[str | None, ...]
    from_pose: bool


def pose_goals(
    robot: Kinematics,
    T_base_tool: np.ndarray,
    q_start: np.ndarray,
    configuration: str | None,
    deadline: Deadline = NO_DEADLINE,
) -> Goals:
    """Every IK solution of ``T_base_tool`` (with ``configuration`` when given), nearest
    ``q_start`` first; ``Unreachable`` when there is none, ``InputError`` for an unknown label."""
    labels = tuple(robot.configuration_labels)
    field = ("goal", "configuration")
    if configuration is not None and configuration not in labels:
        known = ", ".join(labels) if labels else "none"
        raise InputError(
            f"unknown configuration label; this robot's labels are: {known}",
            field=field,
            extra={"configurations": list(labels)},
        )
    Q, found = _solutions(robot, T_base_tool, q_start, deadline)
    if len(Q) == 0:
        raise Unreachable(
            "the goal pose has no IK solution within the joint limits", field=("goal", "pose")
        )
    pick = np.arange(len(Q))
    if configuration is not None:
        pick = np.flatnonzero([c == configuration for c in found])
        if not len(pick):
            have = sorted({c for c in found if c is not None})
            raise Unreachable(
                f"the goal pose has no IK solution with configuration {configuration!r} within "
                f"the joint limits; it has {', '.join(have)}",
                field=field,
                extra={"configurations": have},
            )
    order = pick[np.argsort(np.linalg.norm(Q[pick] - q_start, axis=1), kind="stable")]
    return Goals(Q[order], tuple(found[i] for i in order), True)


def clear_goals(clearance: GroupClearance, goals: Goals, clear: np.ndarray) -> Goals:
    """The candidates whose ``clear`` flag is set; ``Unreachable`` listing every label and the
    pair it collides with when none is."""
    keep = np.flatnonzero(clear)
    if len(keep):
        return Goals(goals.positions[keep], tuple(goals.labels[i] for i in keep), goals.from_pose)
    rows: list[dict[str, object]] = []
    parts = []
    for q, label in zip(goals.positions, goals.labels, strict=True):
        (a, b), d, _ = clearance.closest_pair(q)
        rows.append({"configuration": label, "links": [a, b], "distance": d})
        parts.append(f"{label or 'solution'}: {a} and {b}")
    listed = "; ".join(parts)
    raise Unreachable(
        f"every IK solution of the goal pose is in collision ({listed})",
        field=("goal", "pose"),
        extra={"solutions": rows},
    )


def _solutions(
    robot: Kinematics, T_base_tool: np.ndarray, q_start: np.ndarray, deadline: Deadline
) -> tuple[np.ndarray, tuple[str | None, ...]]:
    """IK solutions ``(k, dof)`` of ``T_base_tool`` and their labels: with the redundant joints
    held at the start's values, else at ``REDUNDANT_VALUES`` values over their limits (one value
    index for every redundant joint together; duplicates within 1e-9 rad dropped)."""
    sols = robot.ik_all(T_base_tool, q_start)
    Q = np.asarray(sols.positions, dtype=float).reshape(-1, robot.dof)
    held = [robot.joint_names.index(name) for name in robot.redundant_joints]
    if len(Q) or not held:
        return Q, tuple(sols.configurations)
    lo, hi = robot.position_limits[held, 0], robot.position_limits[held, 1]
    rows: list[np.ndarray] = []
    labels: list[str | None] = []
    for f in (np.arange(REDUNDANT_VALUES) + 0.5) / REDUNDANT_VALUES:
        deadline.check("IK of the goal pose")
        seed = np.asarray(q_start, dtype=float).copy()
        seed[held] = lo + f * (hi - lo)
        sols = robot.ik_all(T_base_tool, seed)
        for q, label in zip(
            np.asarray(sols.positions, dtype=float).reshape(-1, robot.dof),
            sols.configurations,
            strict=True,
        ):
            if not any(np.abs(q - r).max() <= 1e-9 for r in rows):
                rows.append(q)
                labels.append(label)
    return np.array(rows).reshape(-1, robot.dof), tuple(labels)
