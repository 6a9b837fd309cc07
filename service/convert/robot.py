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

from core.errors import InputError, JointLimit
from core.kinematics import Kinematics
from core.limits import JointLimits, check_positions
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
    robot: Kinematics, values: Sequence[float], field: tuple[str | int, ...]
) -> np.ndarray:
    """``values`` as positions of ``robot`` ``(dof,)`` [rad or m]: one per joint (``InputError`` at
    ``field``) and inside the position limits with the slack of every joint-space check
    (``core.limits.check_positions``: ``JointLimit`` at ``field + (joint,)``, adding ``joint_name``
    and its ``limits``)."""
    q = np.asarray(values, dtype=float)
    if q.shape != (robot.dof,):
        where = ".".join(map(str, field))
        raise InputError(f"{where} needs {robot.dof} values, one per joint", field=field)
    try:
        limits = JointLimits(position=robot.position_limits)
        check_positions(q[None], limits, robot.joint_names, field=field)
    except JointLimit as err:
        j = int(err.joint or 0)
        name, bounds = robot.joint_names[j], robot.position_limits[j].tolist()
        err.extra.update({"joint_name": name, "limits": bounds})
        raise
    return q
