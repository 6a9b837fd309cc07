"""Requests of the joint-space trajectory endpoints: point-to-point profiles and splines.

Every field carries its unit and bounds (shown on the OpenAPI page). Lengths that must agree (start,
goal, velocities, limits, waypoints, the robot's joints) are checked in ``service/convert/joint.py``
and ``core/``, which answer 422 naming the field. The profile names come from ``PROFILES``.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from core.joint.durations import MIN_DURATION
from core.joint.profiles import PROFILES
from core.joint.splines import MIN_KNOT_SPACING
from service.schemas.common import (
    GRAVITY_FIELD,
    MAX_DURATION,
    MAX_JOINTS,
    MIN_LIMIT,
    TOOL_FIELD,
    Gravity,
    JointAccelerations,
    JointPositions,
    JointVelocities,
    Limits,
    RobotRef,
    Sampling,
    StrictModel,
    Tool,
)
from service.schemas.environment import Environment
from service.schemas.registry import RegistryKey

MAX_WAYPOINTS = 10_000
"""Most waypoints of one spline request."""

MAX_JERK = 1e8
"""Largest joint jerk limit [rad/s^3 or m/s^3] accepted."""
Profile = Annotated[str, RegistryKey(PROFILES, "profile")]
"""The joint profiles: the keys of ``core.joint.profiles.PROFILES``."""
Boundary = Literal["clamped", "natural", "not-a-knot"]
KnotTime = Annotated[float, Field(ge=0.0, le=MAX_DURATION)]

ROBOT_DESCRIPTION = (
    'Optional. A registered robot name (for example "ur5") or an inline URDF model. It supplies '
    "joint names, position limits (boundary values and every sample must stay inside them: 422 "
    "joint_limit) and velocity/acceleration limits (overridden field by field by `limits`). Its "
    "number of joints must match the request's arrays. Without it, joints are named j1..jn."
)
LIMITS_DESCRIPTION = (
    "Per-joint velocity [rad/s or m/s] and acceleration [rad/s^2 or m/s^2] limits, each > 0, one "
    "per joint; each list given replaces the robot's. Needed (here or from a robot) unless the "
    "timing is given."
)
PositiveJerk = Annotated[float, Field(ge=MIN_LIMIT, le=MAX_JERK)]


class JointLimitsIn(Limits):
    """Per-joint limits of a point-to-point move, with jerk (used by ``jerk_limited`` only) and
    effort (without ``duration`` only)."""

    jerk: list[PositiveJerk] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_JOINTS,
        description="Jerk limits [rad/s^3 or m/s^3], 1e-6 to 1e8, one per joint; replaces the "
        "robot's. jerk_limited needs them (here or from the robot: Panda 7500 rad/s^3).",
    )


class BoundaryState(StrictModel):
    """Joint state at one end of a move."""

    positions: JointPositions = Field(
        description="Joint positions [rad or m], one per joint (1-64), each |.| <= 1e4."
    )
    velocities: JointVelocities | None = Field(
        default=None,
        description="Joint velocities [rad/s or m/s], each |.| <= 1e4; default zeros. Non-zero "
        "only for cubic, quintic and jerk_limited.",
    )
    accelerations: JointAccelerations | None = Field(
        default=None,
        description="Joint accelerations [rad/s^2 or m/s^2], each |.| <= 1e6; default zeros. "
        "Non-zero only for quintic and jerk_limited.",
    )


class JointTrajectoryRequest(Sampling):
    """``POST /v1/trajectories/joint``: a point-to-point move with one profile for every joint."""

    robot: RobotRef | None = Field(default=None, description=ROBOT_DESCRIPTION)
    tool: Tool | None = TOOL_FIELD
    environment: Environment | None = Field(
        default=None, description="Obstacles, clearance, self-collision (API.md, Environment)."
    )
    profile: Profile = Field(
        description="linear (constant velocity; velocity steps at the ends), cubic, quintic, "
        "trapezoidal (synchronized: the slowest joint sets the duration, a triangle when the "
        "cruise speed is not reached), or jerk_limited (Ruckig: time-optimal under velocity, "
        "acceleration and jerk limits, any boundary velocities and accelerations, every joint "
        "finishing together)."
    )
    start: BoundaryState = Field(description="State at t = 0.")
    goal: BoundaryState = Field(description="State at t = duration.")
    duration: float | None = Field(
        default=None,
        ge=MIN_DURATION,
        le=MAX_DURATION,
        description="Duration [s], 1e-3 <= duration <= 1e5. Absent: the shortest duration that "
        "keeps every joint within the velocity and acceleration (and, for jerk_limited, jerk) "
        "limits. A duration that breaks known limits is 422 joint_rate_limit (jerk_limited: 422 "
        "infeasible naming the shortest feasible duration).",
    )
    limits: JointLimitsIn | None = Field(default=None, description=LIMITS_DESCRIPTION)
    gravity: Gravity | None = GRAVITY_FIELD


class SplineRequest(Sampling):
    """``POST /v1/trajectories/spline``: a C2 cubic spline through every waypoint at its time."""

    robot: RobotRef | None = Field(default=None, description=ROBOT_DESCRIPTION)
    tool: Tool | None = TOOL_FIELD
    environment: Environment | None = Field(
        default=None, description="Obstacles, clearance, self-collision (API.md, Environment)."
    )
    waypoints: list[JointPositions] = Field(
        min_length=2,
        max_length=MAX_WAYPOINTS,
        description="2 to 10,000 joint position vectors [rad or m], each |.| <= 1e4, all of one "
        "length (the number of joints, 1-64).",
    )
    times: list[KnotTime] | None = Field(
        default=None,
        min_length=2,
        max_length=MAX_WAYPOINTS,
        description=f"Time of each waypoint [s]: starts at 0.0, strictly increasing by at least "
        f"{MIN_KNOT_SPACING:g} s, at most 1e5. Absent: allocated from the limits.",
    )
    boundary: Boundary = Field(
        description="clamped (end velocities given, default zero: rest to rest), natural (zero "
        "end accelerations), or not-a-knot. With 2 waypoints natural and not-a-knot give the "
        "straight line, with 3 not-a-knot gives the parabola through them."
    )
    start_velocity: JointVelocities | None = Field(
        default=None,
        description="Velocity at the first waypoint [rad/s or m/s], each |.| <= 1e4; clamped only, "
        "default zeros.",
    )
    goal_velocity: JointVelocities | None = Field(
        default=None,
        description="Velocity at the last waypoint [rad/s or m/s], each |.| <= 1e4; clamped only, "
        "default zeros.",
    )
    limits: Limits | None = Field(default=None, description=LIMITS_DESCRIPTION)
    gravity: Gravity | None = GRAVITY_FIELD
