"""Shared schema pieces: the strict base model, bounded numbers and arrays, robots, sampling.

Every model forbids unknown fields and non-finite numbers (NaN, Infinity), and every number has a
documented physical bound, so no request can make the service emit an infinite number.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

import numpy as np
from fastapi import Query
from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from core.geometry.so3 import QUAT_NORM_TOLERANCE, matrix_to_pose, pose_to_matrix
from core.trajectory import MAX_DURATION  # longest trajectory [s], given or planned

MAX_JOINTS = 64
MAX_POSITION = 1e4
"""Largest |joint position| [rad or m] and |Cartesian coordinate| [m] accepted."""
MAX_VELOCITY = 1e4
"""Largest |joint velocity| [rad/s or m/s] accepted, in boundary conditions and limits."""
MAX_ACCELERATION = 1e6
"""Largest |joint acceleration| [rad/s^2 or m/s^2] accepted."""
MAX_URDF_BYTES = 1024 * 1024


class StrictModel(BaseModel):
    """Base of every request model: unknown fields, NaN/Infinity and values of the wrong JSON type
    (``true`` or ``"1.5"`` where a number goes, ``2.5`` where an integer goes) are 422."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


Position = Annotated[float, Field(ge=-MAX_POSITION, le=MAX_POSITION)]
Velocity = Annotated[float, Field(ge=-MAX_VELOCITY, le=MAX_VELOCITY)]
Acceleration = Annotated[float, Field(ge=-MAX_ACCELERATION, le=MAX_ACCELERATION)]
MIN_LIMIT = 1e-6
"""Smallest joint velocity [rad/s or m/s] or acceleration [rad/s^2 or m/s^2] limit accepted: a
positive limit below it is no physical limit, and its ratios overflow."""
PositiveVelocity = Annotated[float, Field(ge=MIN_LIMIT, le=MAX_VELOCITY)]
PositiveAcceleration = Annotated[float, Field(ge=MIN_LIMIT, le=MAX_ACCELERATION)]

ConfigurationLabel = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_-]+$")]
"""A configuration label a goal pose's IK solution must carry (1-64 of ``[A-Za-z0-9_-]``)."""
JointPositions = Annotated[
    list[Position],
    Field(
        min_length=1,
        max_length=MAX_JOINTS,
        description="Joint positions [rad or m], one per joint.",
    ),
]
JointVelocities = Annotated[
    list[Velocity],
    Field(min_length=1, max_length=MAX_JOINTS, description="Joint velocities [rad/s or m/s]."),
]
JointAccelerations = Annotated[
    list[Acceleration],
    Field(
        min_length=1, max_length=MAX_JOINTS, description="Joint accelerations [rad/s^2 or m/s^2]."
    ),
]


class InlineRobot(StrictModel):
    """A robot sent as URDF text: kinematics only, meshes are never loaded."""

    urdf: str = Field(
        min_length=1,
        max_length=MAX_URDF_BYTES,
        description="URDF XML, at most 1 MiB and 64 joints; revolute, prismatic, continuous, fixed.",
    )
    tip_frame: str | None = Field(
        default=None,
        min_length=1,
        max_length=256,
        description="Tool frame (link) name. Default: the end of the chain below the base (tool0 "
        "when it is one of the last links, else the deepest); a tree that branches (fingers, two "
        "arms) has none: 422 invalid_urdf listing the candidate links.",
    )
    base_frame: str | None = Field(
        default=None,
        min_length=1,
        max_length=256,
        description="Base frame (link) name; default: the URDF's root link.",
    )


RobotRef = Annotated[
    str | InlineRobot,
    Field(
        description='A registered robot name (for example "ur5") or an inline URDF model.',
        union_mode="left_to_right",
    ),
]


MAX_EFFORT = 1e6
"""Largest joint effort limit [N m or N] accepted."""
PositiveEffort = Annotated[float, Field(ge=MIN_LIMIT, le=MAX_EFFORT)]
MAX_GRAVITY = 1e3
"""Largest |gravity component| [m/s^2] accepted."""
EFFORT_DESCRIPTION = (
    "Effort limits [N m or N], 1e-6 to 1e6, one per joint: the inverse-dynamics torque (gravity "
    "included) along the returned motion stays within them (verified densely). Needs a robot with "
    "dynamics (GET /v1/robots/{name}: dynamics true), else 422 validation here; 422 infeasible "
    "naming the joint and s where gravity alone exceeds a limit. Not applied unless given."
)
GRAVITY_FIELD: Any = Field(
    default=None,
    min_length=3,
    max_length=3,
    description="Gravity [m/s^2] in the robot's base frame, each |.| <= 1e3; default [0, 0, -9.81]. "
    "Used for limits.effort and peak_effort (robots with dynamics only).",
)
Gravity = list[Annotated[float, Field(ge=-MAX_GRAVITY, le=MAX_GRAVITY)]]


class Limits(StrictModel):
    """Per-joint limits overriding the robot's (or required when no robot is named)."""

    velocity: list[PositiveVelocity] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_JOINTS,
        description="Speed limits [rad/s or m/s], 1e-6 to 1e4.",
    )
    acceleration: list[PositiveAcceleration] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_JOINTS,
        description="Acceleration limits [rad/s^2 or m/s^2], 1e-6 to 1e6.",
    )
    effort: list[PositiveEffort] | None = Field(
        default=None, min_length=1, max_length=MAX_JOINTS, description=EFFORT_DESCRIPTION
    )


class EffortLimits(StrictModel):
    """Effort limits of a request whose path the service times (Cartesian requests, programs)."""

    effort: list[PositiveEffort] | None = Field(
        default=None, min_length=1, max_length=MAX_JOINTS, description=EFFORT_DESCRIPTION
    )


def not_with(value: Any, info: ValidationInfo, others: tuple[str, ...], message: str) -> Any:
    """A field validator's body for two fields that exclude each other: ``value`` (given) is
    rejected with ``message`` when any of ``others`` (declared before it) is given too, so the
    error's ``loc`` names the field rather than the whole body."""
    if value is not None and any(info.data.get(name) is not None for name in others):
        raise ValueError(message)
    return value


class Sampling(StrictModel):
    """How the returned trajectory is sampled: a period or a count, not both."""

    sample_period: float | None = Field(
        default=None,
        gt=0,
        le=MAX_DURATION,
        description="Spacing of the returned points [s] (default 0.01); at most 100,000 points.",
    )
    samples: int | None = Field(
        default=None,
        ge=2,
        le=100_000,
        description="Number of returned points, evenly spaced in time.",
    )

    @field_validator("samples")
    @classmethod
    def _one_of_period_or_count(cls, value: Any, info: ValidationInfo) -> Any:
        return not_with(value, info, ("sample_period",), "give sample_period or samples, not both")


TimeFormat = Literal["float", "ros"]

TIME_FORMAT_QUERY: Any = Query(
    "float",
    description="float: time_from_start in seconds; ros: a ROS Duration {sec, nanosec} "
    "(0 <= nanosec < 1e9), converted through integer nanoseconds.",
)

Layout = Literal["points", "columns"]

LAYOUT_QUERY: Any = Query(
    "points",
    description="points: `points`, one ROS-shaped object per sample (default); columns: "
    '`"layout": "columns"` and the samples as four arrays at the top level: `time_from_start` '
    "(n), `positions`, `velocities`, `accelerations` (n rows of one value per joint). Same "
    "numbers; columns is smaller and faster to encode and parse.",
)
"""The ``?time_format=`` query parameter of every trajectory-returning route."""


class RosDuration(BaseModel):
    sec: int = Field(description="Whole seconds.")
    nanosec: int = Field(ge=0, lt=1_000_000_000, description="Nanoseconds, < 1e9.")


class TrajectoryPoint(BaseModel):
    time_from_start: float | RosDuration = Field(
        description="Time [s] from the start (a ROS Duration with ?time_format=ros)."
    )
    positions: list[float] = Field(description="Joint positions [rad or m].")
    velocities: list[float] = Field(description="Joint velocities [rad/s or m/s].")
    accelerations: list[float] = Field(description="Joint accelerations [rad/s^2 or m/s^2].")


class Diagnostics(BaseModel):
    model_config = ConfigDict(extra="allow")

    method: str = Field(description="Planning method or profile used.")
    duration: float = Field(description="Trajectory duration [s].")
    compute_time_ms: float = Field(description="Planning time on the server [ms].")
    peak_velocity: list[float] = Field(description="Largest |velocity| per joint [rad/s or m/s].")
    peak_acceleration: list[float] = Field(
        description="Largest |acceleration| per joint [rad/s^2 or m/s^2]."
    )
    warnings: list[str] = Field(description="Things the client should know (slow-downs, clipping).")


class TrajectoryResponse(BaseModel):
    """A superset of ROS trajectory_msgs/JointTrajectory."""

    model_config = ConfigDict(extra="allow")

    joint_names: list[str]
    points: list[TrajectoryPoint]
    diagnostics: Diagnostics


class ColumnsTrajectoryResponse(BaseModel):
    """The same trajectory with ``?layout=columns``: the samples as arrays at the top level."""

    model_config = ConfigDict(extra="allow")

    joint_names: list[str]
    layout: Literal["columns"]
    time_from_start: list[float] | list[RosDuration] = Field(
        description="Time [s] of each sample (ROS Durations with ?time_format=ros)."
    )
    positions: list[list[float]] = Field(description="One row of joint positions per sample.")
    velocities: list[list[float]] = Field(description="One row of joint velocities per sample.")
    accelerations: list[list[float]] = Field(
        description="One row of joint accelerations per sample."
    )
    diagnostics: Diagnostics


class ValidationItem(BaseModel):
    loc: list[str | int]
    msg: str


class Problem(BaseModel):
    """application/problem+json (RFC 9457)."""

    model_config = ConfigDict(extra="allow")

    type: str
    title: str
    status: int
    detail: str
    code: str = Field(description="Machine-readable failure code (see API.md).")
    s: float | None = Field(default=None, description="Path parameter in [0, 1] of a failure.")
    errors: list[ValidationItem] | None = None


PROBLEM_RESPONSES: dict[int | str, dict[str, Any]] = {
    404: {"model": Problem, "description": "Unknown robot or frame"},
    413: {"model": Problem, "description": "Body over 2 MiB"},
    422: {"model": Problem, "description": "Invalid request or planning failure"},
}


Quaternion = Annotated[float, Field(ge=-1.001, le=1.001)]


class Pose(StrictModel):
    """A tool pose in the robot's base frame.

    ``orientation`` is a quaternion in ROS order (x, y, z, w); one whose norm is off 1 by more than
    1e-3 is rejected, otherwise it is normalized. ``as_matrix()`` gives ``T_base_tool`` (4x4).
    """

    position: list[Position] = Field(
        min_length=3, max_length=3, description="Tool position [x, y, z] in [m], each |.| <= 1e4."
    )
    orientation: list[Quaternion] = Field(
        min_length=4,
        max_length=4,
        description="Unit quaternion [x, y, z, w] (ROS order); norm within 1e-3 of 1, normalized.",
    )

    @field_validator("orientation")
    @classmethod
    def _unit_quaternion(cls, q: list[float]) -> list[float]:
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > QUAT_NORM_TOLERANCE:
            raise ValueError("quaternion norm must be within 1e-3 of 1")
        return [v / norm for v in q]

    def as_matrix(self) -> np.ndarray:
        """``T_base_tool`` (4, 4)."""
        return pose_to_matrix(np.array(self.position), np.array(self.orientation))

    @classmethod
    def from_matrix(cls, T: np.ndarray) -> Pose:
        """The pose of ``T`` (4, 4); the quaternion has ``w >= 0``."""
        p, q = matrix_to_pose(T)
        return cls.model_construct(position=p.tolist(), orientation=q.tolist())


MAX_TOOL_OFFSET = 10.0
"""[m] Largest tool offset from the tip frame, per coordinate (``robots.tool.MAX_TOOL_OFFSET``)."""
ToolOffset = Annotated[float, Field(ge=-MAX_TOOL_OFFSET, le=MAX_TOOL_OFFSET)]


class Tool(Pose):
    """A tool offset (TCP): the tool frame's pose in the robot's tip frame.

    Poses, lines, arcs, IK, configuration labels, FK and diagnostics then refer to the tool frame.
    ``orientation`` as in every pose: a quaternion in ROS order (x, y, z, w), norm within 1e-3 of 1,
    normalized. ``as_matrix()`` gives ``T_tip_tool`` (4x4).
    """

    position: list[ToolOffset] = Field(  # type: ignore[assignment]
        min_length=3,
        max_length=3,
        description="Tool origin [x, y, z] in the tip frame [m], each |.| <= 10.",
    )


TOOL_FIELD: Any = Field(
    default=None,
    description="A tool offset (TCP): the tool frame's pose in the tip frame (position [m], "
    "quaternion x, y, z, w). Poses, lines, arcs, IK and diagnostics then refer to the tool frame. "
    "Default: none (the tip frame).",
)
"""The ``tool`` field of every request that names a robot."""


def trajectory_responses(model: type[BaseModel]) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` of a route answering ``model`` (200) or problem+json."""
    return {
        200: {
            "model": model | ColumnsTrajectoryResponse,  # type: ignore[operator]
            "description": "The planned trajectory (ROS-shaped points, or ?layout=columns)",
        },
        **PROBLEM_RESPONSES,
    }
