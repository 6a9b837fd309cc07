"""Requests and responses of ``POST /v1/trajectories/program`` (motion programs, API.md).

A program is a start configuration and 1 to 100 segments (``ptp``, ``lin``, ``circ``, told apart
by ``type``), each from where the last ended. Lengths that depend on the robot (joint arrays) are
checked in ``service/routes/program.py``; blend radii against segment lengths in the core.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator, model_validator

from core.cartesian.methods import METHODS
from core.joint.profiles import PROFILES
from core.program.segments import MAX_SEGMENTS, ptp_profile
from core.timing import PROGRAM_DEFAULT, TIMING_LAWS, program_law, speed_profile_law
from service.schemas.cartesian import (
    MAX_ANGULAR_ACCELERATION,
    MAX_ANGULAR_SPEED,
    MAX_LINEAR_ACCELERATION,
    MAX_LINEAR_SPEED,
    CartesianGoal,
    Tolerance,
)
from service.schemas.collision_free import MAX_SEED
from service.schemas.common import (
    GRAVITY_FIELD,
    TOOL_FIELD,
    ConfigurationLabel,
    EffortLimits,
    Gravity,
    JointPositions,
    Pose,
    Position,
    RobotRef,
    RosDuration,
    StrictModel,
    Tool,
    TrajectoryResponse,
    not_with,
)
from service.schemas.environment import Environment
from service.schemas.registry import RegistryKey

MAX_LINEAR_JERK = 1e5
"""Largest ``max_linear_jerk`` [m/s^3] accepted."""
MAX_ANGULAR_JERK = 1e6
"""Largest ``max_angular_jerk`` [rad/s^3] accepted."""
MAX_BLEND_RADIUS = 10.0
"""Largest ``blend_radius`` [m] accepted (it must also be at most half of either neighbour)."""

Point3 = Annotated[
    list[Position],
    Field(min_length=3, max_length=3, description="A point [x, y, z] in [m] in the base frame."),
]
Scale = Annotated[float, Field(gt=0.0, le=1.0)]
PtpProfile = Annotated[str, RegistryKey(PROFILES, "profile", ptp_profile)]
"""The joint profiles a PTP between stops may take: the keys of ``core.joint.profiles.PROFILES``
held to acceleration limits (not ``linear``, whose velocity steps)."""
SegmentMethod = Annotated[str, RegistryKey(METHODS, "method")]
"""A LIN/CIRC segment's method: any key of ``core.cartesian.methods.METHODS``."""
SpeedProfile = Annotated[str, RegistryKey(TIMING_LAWS, "speed_profile", speed_profile_law)]
"""A LIN/CIRC segment's timing law: a key of ``core.timing.TIMING_LAWS`` that times a Cartesian
path (``trapezoidal``: the program's timing; ``s_curve``)."""
ProgramTiming = Annotated[str, RegistryKey(TIMING_LAWS, "timing", program_law)]
"""A program's timing: a key of ``core.timing.TIMING_LAWS`` in ``JOINT_PATH_LAWS``
(``time_optimal``, ``jerk_limited``)."""
BlendRadius = Annotated[
    float,
    Field(
        ge=0.0,
        le=MAX_BLEND_RADIUS,
        description="Radius [m] of the blend sphere about this segment's goal position, 0 to 10 "
        "(default 0: stop at the goal). At most half of either neighbouring segment's length, "
        "spheres must not overlap; the last segment has none.",
    ),
]


class ProgramStart(StrictModel):
    positions: JointPositions = Field(
        description="Start joint positions [rad or m], one per joint, inside the limits."
    )


class PtpGoal(StrictModel):
    """Goal joint positions, or a tool pose (IK nearest the current joints, with a label)."""

    positions: JointPositions | None = Field(default=None, description="Goal joints [rad or m].")
    pose: Pose | None = Field(default=None, description="Goal tool pose in the base frame.")
    configuration: ConfigurationLabel | None = Field(
        default=None,
        description="Configuration label the IK solution must carry (with pose; robots that "
        "have labels, e.g. UR5 `left-up-noflip`): the solution with this label nearest the "
        "current joints. Without it: the solution nearest the current joints. A label the pose "
        "has no solution with is 422 `unreachable` with `segment` and `configurations` (the "
        "labels it has); a label the robot does not know is 422 `validation` here.",
    )

    @model_validator(mode="after")
    def _one_of(self) -> Any:
        if (self.pose is None) == (self.positions is None):
            raise ValueError("give exactly one of goal.pose or goal.positions")
        if self.configuration is not None and self.pose is None:
            raise ValueError("configuration goes with goal.pose")
        return self


class _Common(StrictModel):
    velocity_scale: Scale = Field(
        default=1.0, description="Share (0, 1] of the joint velocity limits (default 1)."
    )
    acceleration_scale: Scale = Field(
        default=1.0, description="Share (0, 1] of the joint acceleration limits (default 1)."
    )
    blend_radius: BlendRadius = 0.0


class PtpSegment(_Common):
    """Joint-space motion to the goal (a straight line in joint space)."""

    type: Literal["ptp"] = Field(description="ptp: a straight line in joint space.")
    goal: PtpGoal = Field(
        description="Goal joint positions, or a tool pose (IK nearest the joints)."
    )
    profile: PtpProfile | None = Field(
        default=None,
        description="Joint profile of a PTP between stops (no blend into or out of it), rest to "
        "rest, synchronous: every joint follows one normalized profile s(t), so the joint path "
        "is the straight segment; s(t) the fastest of its kind under the joint limits times "
        "velocity_scale/acceleration_scale: `trapezoidal` (acceleration steps at the ramp ends), "
        "`quintic`, "
        "`jerk_limited` (Ruckig, the robot's jerk limits, e.g. Panda 7500 rad/s^3; a robot "
        "without published jerk limits is 422 `validation` here). Absent: the program's common "
        "timing (time-optimal along the path, q'' continuous). Inside a blend a profile has no "
        "meaning (the blend is timed with its neighbours as one motion): it is ignored with a "
        "warning.",
    )

    planner: Literal["collision_free"] | None = Field(
        default=None,
        description="collision_free: the PTP's joint motion is planned around the environment's "
        "obstacles as POST /v1/trajectories/collision_free plans it (the direct segment when it "
        "is clear, else a certified RRT-Connect path, shortened and smoothed; a goal pose tries "
        "its clear IK solutions, nearest first; deterministic per the program's `seed`) and "
        "blends with its neighbours like any PTP; the program's continuous check covers the "
        "whole motion. Needs an `environment` (without one the PTP stays straight); not with "
        "`profile`. No path within the time budget: 422 no_path_found.",
    )


class _CartesianSegment(_Common):
    goal: CartesianGoal = Field(
        description="Goal tool pose, or goal joints (their FK is the pose)."
    )
    max_linear_speed: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_LINEAR_SPEED,
        description="Tool speed limit [m/s] (default 0.25).",
    )
    max_angular_speed: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_ANGULAR_SPEED,
        description="Tool angular speed limit [rad/s] (default 1).",
    )
    method: SegmentMethod = Field(
        default="sampled",
        description="The Cartesian method that plans the segment's joint path on its line or arc "
        "(any method of /v1/trajectories/cartesian): its returned points, every 10 tolerances "
        "along the path, are the segment's joint path. sampled (default): IK at each (about "
        "1e-8 m off the path) | bounded_deviation: as few IK knots as keep the path within its "
        "`tolerance` (segment diagnostics.knot_count) | bounded_deviation_nlp, resolved_rate, "
        "resolved_rate_dls.",
    )
    speed_profile: SpeedProfile = Field(
        default="trapezoidal",
        description="`trapezoidal` (default): the program's `timing` (time_optimal or "
        "jerk_limited). `s_curve`: the whole stretch between stops that holds this segment "
        "is timed with continuous path acceleration and bounded path jerk: an S-curve (Ruckig) "
        "through a smooth speed shape that follows the joint and tool speed caps along the "
        "path (slower in sharp blends only), with the tool's linear jerk within "
        "`max_linear_jerk` (checked densely, blend curvature included; over it, the shape is "
        "lowered there) and the S-curve's path jerk within `max_angular_jerk` over the largest "
        "angular rate per unit path, still under the joint velocity/acceleration caps.",
    )
    max_linear_jerk: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_LINEAR_JERK,
        description="s_curve: tool jerk limit [m/s^3] (default 10).",
    )
    max_angular_jerk: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_ANGULAR_JERK,
        description="s_curve: tool angular jerk limit [rad/s^3] (default 20).",
    )
    max_linear_acceleration: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_LINEAR_ACCELERATION,
        description="Tool acceleration limit [m/s^2] along the segment and its blends (default 1).",
    )
    max_angular_acceleration: float | None = Field(
        default=None,
        ge=1e-6,
        le=MAX_ANGULAR_ACCELERATION,
        description="Tool angular acceleration limit [rad/s^2] (default 2).",
    )
    tolerance: Tolerance = Field(
        default_factory=Tolerance,
        description="Position [m] and orientation [rad] tolerance outside the blend spheres.",
    )


class LinSegment(_CartesianSegment):
    """The tool's straight line to the goal (orientation by slerp)."""

    type: Literal["lin"] = Field(
        description="lin: the tool's straight line (orientation by slerp)."
    )


class CircSegment(_CartesianSegment):
    """The tool point on a circle arc to the goal, through ``interim`` or about ``center``."""

    type: Literal["circ"] = Field(description="circ: the tool point on a circle arc.")
    interim: Point3 | None = Field(
        default=None,
        description="A point [m] the arc passes through (not collinear with its ends).",
    )
    center: Point3 | None = Field(
        default=None,
        description="The circle's centre [m]: equidistant from start and goal within 1e-4 m; the "
        "shorter arc.",
    )

    @model_validator(mode="after")
    def _one_of(self) -> Any:
        if (self.interim is None) == (self.center is None):
            raise ValueError("give exactly one of interim or center")
        return self


ProgramSegment = Annotated[PtpSegment | LinSegment | CircSegment, Field(discriminator="type")]


class ProgramRequest(StrictModel):
    """POST /v1/trajectories/program."""

    robot: RobotRef
    tool: Tool | None = TOOL_FIELD
    environment: Environment | None = Field(
        default=None, description="Obstacles, clearance, self-collision (API.md, Environment)."
    )
    start: ProgramStart = Field(description="Start joint positions of the program.")
    segments: list[ProgramSegment] = Field(
        min_length=1,
        max_length=MAX_SEGMENTS,
        description=f"1 to {MAX_SEGMENTS} segments, each from where the last ended.",
    )
    sample_period: float | None = Field(
        default=None,
        gt=0,
        le=1e5,
        description="Spacing of the regular returned points [s] (default 0.01); segment goals and "
        "blend window boundaries are added.",
    )
    samples: int | None = Field(
        default=None,
        ge=2,
        le=100_000,
        description="Number of regular returned points evenly spaced in time (boundaries added).",
    )
    allow_partial: bool = Field(
        default=False,
        description="On a failing segment: 200 with the program up to it (diagnostics.fraction "
        "< 1, diagnostics.failure with segment) instead of 422.",
    )
    timing: ProgramTiming = Field(
        default=PROGRAM_DEFAULT,
        description="How each stretch between stops is timed (segments[].diagnostics.timing says "
        "which): `time_optimal` (default): the shortest time along the blended joint path that "
        "keeps every joint velocity, acceleration (times each segment's scales) and effort limit "
        "and each LIN/CIRC's tool speed and acceleration limits at every instant (TOPP-RA; the "
        "acceleration steps where the limits switch, each step between two returned points 1e-8 s "
        "apart). `jerk_limited`: round 2's timing, acceleration continuous (C2) everywhere, "
        "slower. A LIN/CIRC with speed_profile s_curve times its stretch as an S-curve under "
        "either.",
    )
    seed: int = Field(
        default=0,
        ge=0,
        le=MAX_SEED,
        description="Seed of the collision-free planner of PTP segments with planner "
        "collision_free (0 to 2^31 - 1): the same program and seed give the same answer.",
    )
    limits: EffortLimits | None = Field(
        default=None,
        description="Effort limits [N m or N] (robots with dynamics): time_optimal keeps them as "
        "constraints; other timings are slowed uniformly until the torque keeps them.",
    )
    gravity: Gravity | None = GRAVITY_FIELD

    @field_validator("samples")
    @classmethod
    def _samples_not_with_period(cls, value: Any, info: ValidationInfo) -> Any:
        return not_with(value, info, ("sample_period",), "give sample_period or samples, not both")


class BlendWindow(BaseModel):
    start_time: float | RosDuration = Field(description="When the blend begins [s].")
    end_time: float | RosDuration = Field(description="When it ends [s] (the next segment begins).")


class SegmentInfo(BaseModel):
    model_config = ConfigDict(extra="allow")

    index: int = Field(description="Position in the request's segments.")
    type: str = Field(description="ptp, lin or circ.")
    start_time: float | RosDuration = Field(
        description="Start of the segment's own part [s] (a ROS Duration with ?time_format=ros)."
    )
    end_time: float | RosDuration = Field(
        description="End of its own part [s] (its goal, or where its blend begins)."
    )
    blend_out: BlendWindow | None = Field(default=None, description="Blend into the next segment.")
    diagnostics: dict[str, Any] = Field(description="Deviation, singular values, skipped.")


class ProgramResponse(TrajectoryResponse):
    """The trajectory plus per-segment times; diagnostics add fraction, max deviations."""

    segments: list[SegmentInfo] = Field(
        description="One entry per requested segment (skipped ones included, none after a "
        "partial plan's failing segment): its time window and its blend window."
    )
