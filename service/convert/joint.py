"""The one place where request models become numpy core inputs, and plans become responses.

Robots: a request's ``robot`` (a registered name or an inline URDF) is resolved by
``service.convert.robot``. The robot supplies the joint names, the
position limits and the velocity/acceleration/jerk limits (jerk: ``None`` where the maker publishes
none); the request's ``limits.velocity``, ``limits.acceleration`` and ``limits.jerk`` each replace
the robot's list when given. The request's arrays must have
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
from core.joint.motion import PointToPoint
from core.kinematics import Dynamics
from core.limits import JointLimits
from core.timing.path_constraints import Effort
from core.trajectory import Trajectory
from robots.model import Robot
from service.convert.dynamics import dynamics_of, effort_inputs, gravity_of
from service.convert.robot import robot_and_names
from service.encoding import base_diagnostics, check_finite, json_response, trajectory_body
from service.schemas.common import Limits
from service.schemas.trajectories import JointLimitsIn, JointTrajectoryRequest, SplineRequest


class JointInputs(NamedTuple):
    """Core inputs of ``core.joint.point_to_point.plan_joint`` (``effort``: ``limits.effort``
    with the robot's dynamics; ``dynamics`` and ``gravity`` for ``peak_effort``)."""

    motion: PointToPoint
    limits: JointLimits
    joint_names: tuple[str, ...]
    robot: Robot | None
    effort: Effort | None = None
    dynamics: Dynamics | None = None
    gravity: np.ndarray | None = None


class SplineInputs(NamedTuple):
    """Inputs of ``core.joint.splines.plan_spline``: arrays ``(n + 1, dof)``, ``(n + 1,)``, ``(dof,)``."""

    waypoints: np.ndarray
    times: np.ndarray | None
    start_velocity: np.ndarray | None
    goal_velocity: np.ndarray | None
    limits: JointLimits
    joint_names: tuple[str, ...]
    robot: Robot | None
    effort: Effort | None = None
    dynamics: Dynamics | None = None
    gravity: np.ndarray | None = None


def joint_limits(limits: Limits | JointLimitsIn | None, robot: Any) -> JointLimits:
    """Request limits over the robot's, field by field; the robot's position limits ``(dof, 2)``."""

    def pick(name: str, robot_attribute: str) -> np.ndarray | None:
        given = getattr(limits, name, None)
        if given is not None:
            return np.asarray(given, dtype=float)
        known = None if robot is None else getattr(robot, robot_attribute)
        return None if known is None else np.asarray(known, dtype=float)

    return JointLimits(
        velocity=pick("velocity", "velocity_limits"),
        acceleration=pick("acceleration", "acceleration_limits"),
        position=None if robot is None else np.asarray(robot.position_limits, dtype=float),
        jerk=pick("jerk", "jerk_limits"),
    )


def joint_inputs(request: JointTrajectoryRequest) -> JointInputs:
    """Move, limits and joint names of a joint-space request."""
    start, goal = request.start, request.goal
    robot, names = robot_and_names(
        request.robot, len(start.positions), ("start", "positions"), request.tool
    )
    motion = PointToPoint.create(
        start.positions,
        goal.positions,
        start.velocities,
        goal.velocities,
        start.accelerations,
        goal.accelerations,
    )
    dof = len(start.positions)
    return JointInputs(
        motion,
        joint_limits(request.limits, robot),
        names,
        robot,
        effort_inputs(request, robot, dof),
        dynamics_of(robot),
        gravity_of(request, robot),
    )


def spline_inputs(request: SplineRequest) -> SplineInputs:
    """Waypoints, times, end velocities, limits and joint names of a spline request."""
    dof = len(request.waypoints[0])
    for i, waypoint in enumerate(request.waypoints):
        if len(waypoint) != dof:
            raise InputError(
                f"waypoints.{i} needs {dof} values like waypoints.0", field=("waypoints", i)
            )
    robot, names = robot_and_names(request.robot, dof, ("waypoints", 0), request.tool)

    def array(value: list[float] | None) -> np.ndarray | None:
        return None if value is None else np.asarray(value, dtype=float)

    return SplineInputs(
        np.asarray(request.waypoints, dtype=float),
        array(request.times),
        array(request.start_velocity),
        array(request.goal_velocity),
        joint_limits(request.limits, robot),
        names,
        robot,
        effort_inputs(request, robot, dof),
        dynamics_of(robot),
        gravity_of(request, robot),
    )


def effort_diagnostics(plan: Any) -> dict[str, Any]:
    """``peak_effort`` [N m or N] per joint of a plan whose robot has dynamics; nothing otherwise."""
    return {} if plan.peak_effort is None else {"peak_effort": plan.peak_effort}


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
    return json_response(trajectory_body(trajectory, diag, time_format, encoded=True))
