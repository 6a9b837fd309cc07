"""Robot resolution for every request: a registered name or an inline URDF -> ``robots.model.Robot``.

``resolve_robot`` turns a request's ``robot`` (and its ``tool`` offset) into a robot (404
``unknown_robot`` and 422 ``invalid_urdf`` come from the registry); ``robot_and_names`` also checks that the request's arrays
have the robot's number of joints (422 ``validation`` naming the field) and gives the joint names
(``j1..jn`` without a robot). ``robot_positions`` is the entry check of a request's joint positions
(one per joint, inside the position limits), the same for every route that takes them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from core.errors import InputError
from core.kinematics import Kinematics
from core.limits import entry_positions
from core.trajectory import default_joint_names
from robots.model import Robot
from robots.registry import resolve
from service.memo import robot_key, shared
from service.schemas.common import InlineRobot, Tool


def with_tool(robot: Robot, tool: Tool | None) -> Robot:
    """``robot`` answering for the request's ``tool`` frame (a TCP offset), or itself without one."""
    return robot if tool is None else robot.with_tool(tool.as_matrix())


@shared("robot", robot_key)
def _named(ref: str | InlineRobot) -> Robot:
    """The parsed robot a reference names (shared by the steps of a request and a batch's items)."""
    return resolve(ref if isinstance(ref, str) else ref.model_dump())


def resolve_robot(ref: str | InlineRobot | None, tool: Tool | None = None) -> Robot | None:
    """The ``Robot`` a request names (with its ``tool`` offset), or ``None`` when it names none."""
    if ref is None:
        return None
    return with_tool(_named(ref), tool)


def robot_and_names(
    ref: str | InlineRobot | None,
    dof: int,
    field: tuple[str | int, ...],
    tool: Tool | None = None,
) -> tuple[Robot | None, tuple[str, ...]]:
    """The robot and its joint names; ``InputError`` at ``field`` when ``dof`` is not its count."""
    robot = resolve_robot(ref, tool)
    if robot is None:
        return None, default_joint_names(dof)
    if robot.dof != dof:
        raise InputError(
            f"the robot has {robot.dof} joints but {'.'.join(map(str, field))} has {dof} values",
            field=field,
        )
    return robot, tuple(robot.joint_names)


def robot_positions(
    robot: Kinematics,
    values: Sequence[float],
    field: tuple[str | int, ...],
    *,
    s: float | None = None,
) -> np.ndarray:
    """``values`` as positions of ``robot`` ``(dof,)`` [rad or m]: the one entry check of every
    route (``core.limits.entry_positions``: one finite value per joint, ``InputError`` at
    ``field``; inside the position limits with the slack of every planner, ``JointLimit`` at
    ``field + (joint,)`` with ``joint_name``, its ``limits`` and ``s``)."""
    return entry_positions(values, robot.position_limits, robot.joint_names, field, s=s)
