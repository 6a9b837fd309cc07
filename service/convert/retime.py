"""``POST /v1/trajectories/retime``: request -> ``core.joint.retime.plan_retime`` inputs, and the
plan's diagnostics (``timing``, ``binding``, ``path_length``, ``peak_effort``,
``time_optimal_duration``).

Limits as for the other joint-space routes (``service.convert.joint.joint_limits``: the request's
lists replace the robot's, position limits from the robot); without a robot velocity and
acceleration limits are required (core names the field); jerk limits only as the request gives them
(core checks the path kind). Tool speed limits need a robot (422 ``validation`` at the field) and
hold at the ``tool`` frame when one is given (``with_tool``);
effort limits a robot with dynamics (``service.convert.dynamics``).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from core.errors import InputError
from core.joint.retime import DEFAULT_MAX_DEVIATION, RetimePlan
from core.kinematics import Dynamics
from core.limits import JointLimits
from core.timing.path_constraints import Effort, ToolSpeed, tool_rates
from robots.model import Robot
from service.convert.dynamics import dynamics_of, effort_inputs, gravity_of
from service.convert.joint import joint_limits
from service.convert.robot import robot_and_names, with_tool
from service.schemas.retime import RetimeRequest


class RetimeInputs(NamedTuple):
    """Everything ``plan_retime`` takes from a request."""

    waypoints: np.ndarray
    limits: JointLimits
    max_deviation: float
    tool: ToolSpeed | None
    effort: Effort | None
    dynamics: Dynamics | None
    gravity: np.ndarray
    joint_names: tuple[str, ...]
    robot: Robot | None


def retime_inputs(body: RetimeRequest) -> RetimeInputs:
    """Waypoints, limits, tool speeds, effort, dynamics and joint names of a retime request."""
    dof = len(body.waypoints[0])
    for i, waypoint in enumerate(body.waypoints):
        if len(waypoint) != dof:
            raise InputError(
                f"waypoints.{i} needs {dof} values like waypoints.0", field=("waypoints", i)
            )
    robot, names = robot_and_names(body.robot, dof, ("waypoints", 0))
    if body.tool is not None and robot is None:
        raise InputError("tool needs a robot", field=("tool",))
    robot = None if robot is None else with_tool(robot, body.tool)
    tool = None
    for name in ("max_linear_speed", "max_angular_speed"):
        if getattr(body, name) is not None and robot is None:
            raise InputError(f"{name} needs a robot", field=(name,))
    if robot is not None and (body.max_linear_speed or body.max_angular_speed) is not None:
        tool = ToolSpeed(tool_rates(robot), body.max_linear_speed, body.max_angular_speed)
    limits = joint_limits(body.limits, robot)
    # jerk only when the request gives it (a robot's published jerk limits do not switch the
    # timing from time-optimal to jerk-limited)
    jerk = None if body.limits is None or body.limits.jerk is None else limits.jerk
    limits = JointLimits(limits.velocity, limits.acceleration, limits.position, jerk)
    return RetimeInputs(
        np.asarray(body.waypoints, dtype=float),
        limits,
        DEFAULT_MAX_DEVIATION if body.max_deviation is None else body.max_deviation,
        tool,
        effort_inputs(body, robot, dof),
        dynamics_of(robot),
        gravity_of(body, robot),
        names,
        robot,
    )


def retime_diagnostics(plan: RetimePlan) -> dict[str, Any]:
    """``timing``, ``binding`` (stretches of the path, as fractions of its length, and the limit
    that binds there), ``path_length`` [rad or m], ``grid_points`` and ``peak_effort``; with jerk
    limits ``time_optimal_duration`` [s] too."""
    names = plan.trajectory.joint_names
    out: dict[str, Any] = {
        "timing": plan.timing_name,
        "binding": [
            {
                "s": [round(b.start, 6), round(b.end, 6)],
                "limit": b.limit,
                "joint": None if b.joint is None else names[b.joint],
            }
            for b in plan.timing.binding
        ],
        "path_length": plan.path_length,
        "grid_points": len(plan.timing.profile.s),
    }
    if plan.time_optimal_duration is not None:
        out["time_optimal_duration"] = plan.time_optimal_duration
    if plan.peak_effort is not None:
        out["peak_effort"] = plan.peak_effort
    return out
