"""Request of ``POST /v1/trajectories/retime``: a geometric joint path through waypoints, timed at the
optimum (units and bounds in every Field; lengths that must agree are checked in
``service/convert/retime.py`` and ``core/``)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, ValidationInfo, field_validator

from core.joint.retime import DEFAULT_MAX_DEVIATION, MAX_WAYPOINTS, PATHS
from service.schemas.common import (
    GRAVITY_FIELD,
    MAX_POSITION,
    MAX_VELOCITY,
    TOOL_FIELD,
    Gravity,
    JointPositions,
    RobotRef,
    Sampling,
    Tool,
)
from service.schemas.environment import Environment
from service.schemas.trajectories import ROBOT_DESCRIPTION, JointLimitsIn

PathKind = Literal[tuple(PATHS)]  # type: ignore[valid-type]


class RetimeRequest(Sampling):
    """``POST /v1/trajectories/retime``: the shortest rest-to-rest timing of a path through
    waypoints under joint velocity, acceleration and effort limits and tool speed limits."""

    robot: RobotRef | None = Field(default=None, description=ROBOT_DESCRIPTION)
    environment: Environment | None = Field(
        default=None, description="Obstacles, clearance, self-collision (API.md, Environment)."
    )
    waypoints: list[JointPositions] = Field(
        min_length=2,
        max_length=MAX_WAYPOINTS,
        description="2 to 10,000 joint position vectors [rad or m], each |.| <= 1e4, all of one "
        "length (the number of joints, 1-64); consecutive waypoints must differ.",
    )
    path: PathKind = Field(  # type: ignore[valid-type]
        default="blended",
        description="blended (default): straight joint segments whose corners are rounded by "
        "circular arcs within max_deviation, as MoveIt's time-optimal trajectory generation; "
        "spline: the C2 cubic through every waypoint in a chord-length path parameter "
        "(not-a-knot ends).",
    )
    max_deviation: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_POSITION,
        description=f"blended only: largest joint-space distance [rad or m] of the path from a "
        f"corner waypoint, > 0, <= 1e4; default {DEFAULT_MAX_DEVIATION:g}. A corner also uses at "
        "most half of either segment.",
    )
    limits: JointLimitsIn | None = Field(
        default=None,
        description="Per-joint velocity [rad/s or m/s] and acceleration [rad/s^2 or m/s^2] limits "
        "(each list replaces the robot's; required without a robot), effort [N m or N] and jerk "
        "[rad/s^3 or m/s^3]: with jerk the motion is jerk-limited (continuous acceleration; "
        "spline paths only, 422 validation at limits.jerk on a blended path). A robot's own jerk "
        "limits are not applied unless given here.",
    )
    gravity: Gravity | None = GRAVITY_FIELD
    max_linear_speed: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_VELOCITY,
        description="Tool speed limit [m/s] (the tool frame's origin: the tip's, or tool's), > 0, "
        "<= 1e4; needs robot.",
    )
    max_angular_speed: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_VELOCITY,
        description="Tool angular speed limit [rad/s], > 0, <= 1e4; needs robot.",
    )
    tool: Tool | None = TOOL_FIELD

    @field_validator("max_deviation")
    @classmethod
    def _blended_only(cls, value: Any, info: ValidationInfo) -> Any:
        if value is not None and info.data.get("path") == "spline":
            raise ValueError("max_deviation applies to blended paths only")
        return value
