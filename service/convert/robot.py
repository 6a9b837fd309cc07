"""Robot resolution for every request: a registered name or an inline URDF -> ``robots.model.Robot``.

``resolve_robot`` turns a request's ``robot`` into a robot (404 ``unknown_robot`` and 422
``invalid_urdf`` come from the registry); ``robot_and_names`` also checks that the request's arrays
have the robot's number of joints (422 ``validation`` naming the field) and gives the joint names
(``j1..jn`` without a robot).
"""

from __future__ import annotations

from core.errors import InputError
from core.trajectory import default_joint_names
from robots.model import Robot
from robots.registry import resolve
from service.memo import robot_key, shared
from service.schemas.common import InlineRobot


@shared("robot", robot_key)
def resolve_robot(ref: str | InlineRobot | None) -> Robot | None:
    """The ``Robot`` a request names, or ``None`` when it names none."""
    if ref is None:
        return None
    return resolve(ref if isinstance(ref, str) else ref.model_dump())


def robot_and_names(
    ref: str | InlineRobot | None, dof: int, field: tuple[str | int, ...]
) -> tuple[Robot | None, tuple[str, ...]]:
    """The robot and its joint names; ``InputError`` at ``field`` when ``dof`` is not its count."""
    robot = resolve_robot(ref)
    if robot is None:
        return None, default_joint_names(dof)
    if robot.dof != dof:
        raise InputError(
            f"the robot has {robot.dof} joints but {'.'.join(map(str, field))} has {dof} values",
            field=field,
        )
    return robot, tuple(robot.joint_names)
