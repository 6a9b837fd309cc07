"""The one place where request models become numpy core inputs, and plans become responses.

Robots: a request's ``robot`` (a registered name or an inline URDF) is resolved by
``robots.registry.resolve`` (imported on first use). The robot supplies the joint names, the
position limits and the velocity/acceleration limits; the request's ``limits.velocity`` and
``limits.acceleration`` each replace the robot's list when given. The request's arrays must have
the robot's number of joints (422 ``validation`` naming the field). Positions outside the position
limits are 422 ``joint_limit`` naming the field and the joint (checked in ``core``, which also
checks every sample of the plan). Without a robot, joints are named ``j1..jn`` and have no
position limits.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np
from starlette.responses import Response

from core.errors import InputError
from core.limits import JointLimits
from core.point_to_point import PointToPoint
from core.trajectory import Trajectory, default_joint_names
from service.encoding import base_diagnostics, check_finite, json_response, trajectory_body
from service.schemas.common import InlineRobot, Limits
from service.schemas.trajectories import JointTrajectoryRequest, SplineRequest


class JointInputs(NamedTuple):
    """Core inputs of ``core.point_to_point.plan_joint``."""

    motion: PointToPoint
    limits: JointLimits
    joint_names: tuple[str, ...]


class SplineInputs(NamedTuple):
    """Inputs of ``core.splines.plan_spline``: arrays ``(n + 1, dof)``, ``(n + 1,)``, ``(dof,)``."""

    waypoints: np.ndarray
    times: np.ndarray | None
    start_velocity: np.ndarray | None
    goal_velocity: np.ndarray | None
    limits: JointLimits
    joint_names: tuple[str, ...]


def resolve_robot(ref: str | InlineRobot | None) -> Any:
    """The ``robots.model.Robot`` a request names, or ``None`` (404 ``unknown_robot``,
    422 ``invalid_urdf`` come from the registry)."""
    if ref is None:
        return None
    from robots.registry import resolve

    return resolve(ref if isinstance(ref, str) else ref.model_dump())


def _robot_and_names(
    ref: str | InlineRobot | None, dof: int, field: tuple[str | int, ...]
) -> tuple[Any, tuple[str, ...]]:
    robot = resolve_robot(ref)
    if robot is None:
        return None, default_joint_names(dof)
    if robot.dof != dof:
        raise InputError(
            f"the robot has {robot.dof} joints but {'.'.join(map(str, field))} has {dof} values",
            field=field,
        )
    return robot, tuple(robot.joint_names)


def joint_limits(limits: Limits | None, robot: Any) -> JointLimits:
    """Request limits over the robot's, field by field; the robot's position limits ``(dof, 2)``."""

    def pick(name: str, robot_attribute: str) -> np.ndarray | None:
        given = None if limits is None else getattr(limits, name)
        if given is not None:
            return np.asarray(given, dtype=float)
        return None if robot is None else np.asarray(getattr(robot, robot_attribute), dtype=float)

    return JointLimits(
        velocity=pick("velocity", "velocity_limits"),
        acceleration=pick("acceleration", "acceleration_limits"),
        position=None if robot is None else np.asarray(robot.position_limits, dtype=float),
    )


def joint_inputs(request: JointTrajectoryRequest) -> JointInputs:
    """Move, limits and joint names of a joint-space request."""
    start, goal = request.start, request.goal
    robot, names = _robot_and_names(request.robot, len(start.positions), ("start", "positions"))
    motion = PointToPoint.create(
        start.positions,
        goal.positions,
        start.velocities,
        goal.velocities,
        start.accelerations,
        goal.accelerations,
    )
    return JointInputs(motion, joint_limits(request.limits, robot), names)


def spline_inputs(request: SplineRequest) -> SplineInputs:
    """Waypoints, times, end velocities, limits and joint names of a spline request."""
    dof = len(request.waypoints[0])
    for i, waypoint in enumerate(request.waypoints):
        if len(waypoint) != dof:
            raise InputError(
                f"waypoints.{i} needs {dof} values like waypoints.0", field=("waypoints", i)
            )
    robot, names = _robot_and_names(request.robot, dof, ("waypoints", 0))

    def array(value: list[float] | None) -> np.ndarray | None:
        return None if value is None else np.asarray(value, dtype=float)

    return SplineInputs(
        np.asarray(request.waypoints, dtype=float),
        array(request.times),
        array(request.start_velocity),
        array(request.goal_velocity),
        joint_limits(request.limits, robot),
        names,
    )


def trajectory_response(
    trajectory: Trajectory,
    method: str,
    warnings: tuple[str, ...],
    started: float,
    time_format: str = "float",
    **diagnostics: Any,
) -> Response:
    """The JSON response of a plan; ``started`` is the ``time.perf_counter()`` at request start."""
    check_finite(trajectory)
    diag = base_diagnostics(trajectory, method, (time.perf_counter() - started) * 1e3)
    diag["warnings"] = list(warnings)
    diag.update(diagnostics)
    return json_response(trajectory_body(trajectory, diag, time_format))
