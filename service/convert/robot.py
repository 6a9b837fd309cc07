"""Robot resolution for every request: a registered name or an inline URDF -> ``robots.model.Robot``.

``resolve_robot`` turns a request's ``robot`` (and its ``tool`` offset) into a robot (404
``unknown_robot`` and 422 ``invalid_urdf`` come from the registry); ``robot_and_names`` also checks that the request's arrays
have the robot's number of joints (422 ``validation`` naming the field) and gives the joint names
(``j1..jn`` without a robot).
"""

from __future__ import annotations

from core.errors import InputError
from core.trajectory import default_joint_names
from robots.model import Robot
from robots.registry import resolve
from service.schemas.common import InlineRobot, Tool


def with_tool(robot: Robot, tool: Tool | None) -> Robot:
    """``robot`` answering for the request's ``tool`` frame (a TCP offset), or itself without one."""
    return robot if tool is None else robot.with_tool(tool.as_matrix())


def resolve_robot(ref: str | InlineRobot | None, tool: Tool | None = None) -> Robot | None:
    """The ``Robot`` a request names (with its ``tool`` offset), or ``None`` when it names none."""
    if ref is None:
        return None
    return with_tool(resolve(ref if isinstance(ref, str) else ref.model_dump()), tool)


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
