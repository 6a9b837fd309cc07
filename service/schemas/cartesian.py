"""Requests and responses of the Cartesian straight-line endpoint (and the task of /v1/compare).

``CartesianTaskSpec`` is everything but the method, so ``/v1/compare`` reuses it as its ``task``;
``CartesianRequest`` adds ``method``. Every field carries its unit and bounds. Lengths that depend
on the robot (``start.positions``, ``goal.positions``) are checked in ``service/convert/cartesian.py``.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from core.cartesian.methods import METHODS
from core.path import PATHS
from core.timing import TIMING_LAWS, speed_profile_law
from service.schemas.common import (
    GRAVITY_FIELD,
    MAX_DURATION,
    TOOL_FIELD,
    EffortLimits,
    Gravity,
    JointPositions,
    Pose,
    Position,
    RobotRef,
    StrictModel,
    Tool,
    TrajectoryResponse,
    not_with,
)
from service.schemas.environment import Environment
from service.schemas.registry import RegistryKey

Method = Annotated[str, RegistryKey(METHODS, "method")]
"""The method names: the keys of ``core.cartesian.methods.METHODS`` (read at validation and at
schema generation): a method added there is accepted here, so the API cannot drift from the code."""

MAX_LINEAR_SPEED = 10.0
"""Largest ``max_linear_speed`` [m/s] accepted."""
MAX_ANGULAR_SPEED = 100.0
"""Largest ``max_angular_speed`` [rad/s] accepted."""
MAX_LINEAR_JERK = 1e4
"""Largest ``max_linear_jerk`` [m/s^3] accepted."""
MAX_ANGULAR_JERK = 1e5
"""Largest ``max_angular_jerk`` [rad/s^3] accepted."""
MAX_LINEAR_ACCELERATION = 1e3
"""Largest ``max_linear_acceleration`` [m/s^2] accepted."""
MAX_ANGULAR_ACCELERATION = 1e4
"""Largest ``max_angular_acceleration`` [rad/s^2] accepted."""

PathType = Annotated[str, RegistryKey(PATHS, "path.type")]
"""The path shapes: the keys of ``core.path.PATHS`` (``line``, ``circ``)."""
SpeedProfile = Annotated[str, RegistryKey(TIMING_LAWS, "speed_profile", speed_profile_law)]
"""The timing laws of a Cartesian path: the keys of ``core.timing.TIMING_LAWS`` outside
``JOINT_PATH_LAWS`` (``trapezoidal``, ``s_curve``)."""
Point3 = Annotated[
    list[Position],
    Field(min_length=3, max_length=3, description="A point [x, y, z] in [m] in the base frame."),
]


class PathShape(StrictModel):
    """The tool path: the straight line (default), or a circle arc through ``interim`` or about
    ``center`` (the shorter arc); orientation by slerp either way."""

    type: PathType = Field(
        default="line",
        description="line (default) | circ: the tool point on the circle arc from FK(start) to "
        "the goal | any other shape of core.path.PATHS.",
    )
    interim: Point3 | None = Field(
        default=None,
        description="circ: a point [m] the arc passes through (not collinear with start and goal).",
    )
    center: Point3 | None = Field(
        default=None,
        description="circ: the circle's centre [m]; start and goal equidistant from it within "
        "1e-4 m; the shorter arc (not a half turn).",
    )

    @model_validator(mode="after")
    def _circle(self) -> Any:
        if self.type != "circ" and (self.interim is not None or self.center is not None):
            raise ValueError(f"a {self.type} path takes no interim or center")
        if self.type == "circ" and (self.interim is None) == (self.center is None):
            raise ValueError("a circ path needs exactly one of interim or center")
        return self


class CartesianStart(StrictModel):
    """Where the arm starts: joint positions; the line starts at their forward kinematics."""

    positions: JointPositions = Field(
        description="Start joint positions [rad or m], one per joint of the robot, inside its limits."
    )


class CartesianGoal(StrictModel):
    """Where the line ends: a tool pose, or joint positions whose forward kinematics is the pose."""

    pose: Pose | None = Field(
        default=None,
        description="Goal tool pose in the robot's base frame (for position_xy robots only x and y count).",
    )
    positions: JointPositions | None = Field(
        default=None,
        description="Goal joint positions [rad or m]: the goal pose is their forward kinematics; the "
        "trajectory ends at them when the line arrives on their branch (else a warning).",
    )

    @model_validator(mode="after")
    def _one_of(self) -> Any:
        if (self.pose is None) == (self.positions is None):
            raise ValueError("give exactly one of goal.pose or goal.positions")
        return self


class Tolerance(StrictModel):
    """Allowed deviation of the tool from the line."""

    position: float = Field(
        default=1e-3,
        ge=1e-6,
        le=1.0,
        description="Position tolerance [m], 1e-6 to 1 (default 0.001).",
    )
    orientation: float = Field(
        default=1e-2,
        ge=1e-6,
        le=math.pi,
        description="Orientation tolerance [rad], 1e-6 to pi (default 0.01).",
    )


class CartesianTaskSpec(StrictModel):
    """A straight-line task: the tool moves on the line from FK(start) to the goal pose."""

    robot: RobotRef
    tool: Tool | None = TOOL_FIELD
    environment: Environment | None = Field(
        default=None, description="Obstacles, clearance, self-collision (API.md, Environment)."
    )
    start: CartesianStart = Field(
        description="Start joint positions; the line starts at their forward kinematics."
    )
    goal: CartesianGoal = Field(
        description="Goal tool pose, or goal joint positions (their forward kinematics)."
    )
    tolerance: Tolerance = Field(
        default_factory=Tolerance,
        description="Position [m] and orientation [rad] tolerance. sampled: sets the IK step along "
        "the line (10 tolerances of travel); bounded deviation: the bound.",
    )
    duration: float | None = Field(
        default=None,
        ge=1e-3,
        le=MAX_DURATION,
        description="Fixed duration [s], 1e-3 <= duration <= 1e5 (a quintic s(t)); joint speeds that "
        "would exceed their limits are 422 joint_rate_limit with the s and min_duration. Not "
        "together with max_linear_speed/max_angular_speed.",
    )
    max_linear_speed: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_LINEAR_SPEED,
        description="Tool speed limit [m/s], 1e-6 <= v <= 10. Without duration and speed limits: 0.25 "
        "m/s and 1 rad/s. Tool accelerations: 1 m/s^2 and 2 rad/s^2. The planner slows down further "
        "where joint velocity or acceleration limits need it (a warning says where).",
    )
    max_angular_speed: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_ANGULAR_SPEED,
        description="Tool angular speed limit [rad/s], 1e-6 <= w <= 100.",
    )
    max_linear_acceleration: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_LINEAR_ACCELERATION,
        description="Tool acceleration limit [m/s^2] of the speed-limited timing, 1e-6 to 1e3 "
        "(default 1). Not together with duration.",
    )
    max_angular_acceleration: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_ANGULAR_ACCELERATION,
        description="Tool angular acceleration limit [rad/s^2], 1e-6 to 1e4 (default 2). Not "
        "together with duration.",
    )
    sample_period: float | None = Field(
        default=None,
        gt=0,
        le=MAX_DURATION,
        description="Spacing of the returned points in time [s] (default 0.01); at most 100,000 points.",
    )
    samples: int | None = Field(
        default=None,
        ge=2,
        le=100_000,
        description="Number of returned points, equally spaced along the line (in s, the notes' N "
        "points), timed by s(t). Not together with sample_period.",
    )
    control_period: float = Field(
        default=1e-3,
        ge=1e-4,
        le=0.1,
        description="Control tick of the resolved-rate methods [s], 1e-4 to 0.1 (default 0.001).",
    )
    allow_partial: bool = Field(
        default=False,
        description="When the line cannot be completed: 200 with the planned prefix (fraction < 1, "
        "diagnostics.failure) instead of 422.",
    )
    allow_violations: bool = Field(
        default=False,
        description="Accept a plan that leaves the tolerance between its returned points or exceeds "
        "a joint's acceleration limit (the warnings say where and by how much). Default: such a "
        "plan is 422 (infeasible or joint_rate_limit) naming the cause and what to change.",
    )
    keep_configuration: bool = Field(
        default=True,
        description="true (default): the trajectory keeps the start's configuration label (a "
        "branch change is 422 branch_flip). false: resolved_rate and resolved_rate_dls may pass a "
        "wrist singularity (the DLS damps through it, rates bounded); "
        "diagnostics.configuration_changes lists each change as {s, from, to}. The other methods "
        "follow one IK branch either way.",
    )
    path: PathShape = Field(
        default_factory=PathShape,
        description='The path shape: {"type": "line"} (default) | {"type": "circ", "interim": '
        '[x, y, z]} | {"type": "circ", "center": [x, y, z]}; bad circle geometry is 422 at path.*.',
    )
    speed_profile: SpeedProfile = Field(
        default="trapezoidal",
        description="trapezoidal (default: speed-limited trapezoid, or quintic with a duration) | "
        "s_curve: path acceleration continuous, path jerk within max_linear_jerk/max_angular_jerk; "
        "joint velocity and acceleration limits still hold.",
    )
    max_linear_jerk: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_LINEAR_JERK,
        description="s_curve: tool jerk limit [m/s^3], 1e-6 to 1e4 (default 10).",
    )
    max_angular_jerk: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_ANGULAR_JERK,
        description="s_curve: tool angular jerk limit [rad/s^3], 1e-6 to 1e5 (default 20).",
    )
    limits: EffortLimits | None = Field(
        default=None,
        description="Effort limits [N m or N] (robots with dynamics): the timing the service "
        "chooses (no duration) is slowed uniformly until the inverse-dynamics torque along the "
        "returned motion keeps them.",
    )
    gravity: Gravity | None = GRAVITY_FIELD
    solver: str = Field(
        default="osqp",
        min_length=1,
        max_length=32,
        pattern=r"^[a-z0-9_]+$",
        description="QP solver of resolved_rate_dls (a qpsolvers name; default osqp).",
    )

    @field_validator(
        "max_linear_speed",
        "max_angular_speed",
        "max_linear_acceleration",
        "max_angular_acceleration",
    )
    @classmethod
    def _speeds_not_with_duration(cls, value: Any, info: ValidationInfo) -> Any:
        message = "give duration or tool speed/acceleration limits, not both"
        return not_with(value, info, ("duration",), message)

    @field_validator("samples")
    @classmethod
    def _samples_not_with_period(cls, value: Any, info: ValidationInfo) -> Any:
        return not_with(value, info, ("sample_period",), "give sample_period or samples, not both")


class CartesianRequest(CartesianTaskSpec):
    """POST /v1/trajectories/cartesian."""

    method: Method = Field(
        description="sampled | bounded_deviation | bounded_deviation_nlp | resolved_rate | "
        "resolved_rate_dls."
    )


class Knot(BaseModel):
    s: float = Field(description="Path parameter in [0, 1].")
    time_from_start: float | dict[str, int] = Field(
        description="Time [s] (ROS Duration with ?time_format=ros)."
    )
    positions: list[float] = Field(description="Joint positions [rad or m].")


class CartesianResponse(TrajectoryResponse):
    """The trajectory; diagnostics add fraction, max_position_deviation [m],
    max_orientation_deviation [rad], min_singular_value, failure (partial plans), profiles."""

    model_config = ConfigDict(extra="allow")

    knots: list[Knot] | None = Field(default=None, description="Bounded-deviation knots.")
