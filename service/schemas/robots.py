"""Request and response models of /v1/robots (units and bounds in every Field)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, Discriminator, Field, StringConstraints, Tag

from service.schemas.common import (
    TOOL_FIELD,
    JointPositions,
    Pose,
    Position,
    RobotRef,
    StrictModel,
    Tool,
)
from service.schemas.environment import Box, CapsuleShape, Cylinder, Sphere

NAME_PATTERN = r"^[A-Za-z0-9_.\-]{1,64}$"
FrameName = Field(
    default=None,
    min_length=1,
    max_length=256,
    description="A link frame of the robot; default the tool (tip) frame.",
)


class RobotSummary(BaseModel):
    name: str = Field(description="Registered robot name.")
    dof: int = Field(description="Number of joints.")
    joint_names: list[str] = Field(description="Joint names, in the order of every joint array.")
    base_frame: str = Field(description="Frame poses and Jacobians are expressed in.")
    tip_frame: str = Field(description="Tool frame.")
    task_space: Literal["pose", "position_xy"] = Field(
        description='"pose": position and orientation count; "position_xy": only the tip\'s x and y.'
    )


class RobotLimits(BaseModel):
    position: list[list[float]] = Field(description="[lower, upper] per joint [rad or m].")
    velocity: list[float] = Field(description="Speed limit per joint [rad/s or m/s], > 0.")
    acceleration: list[float] = Field(
        description="Acceleration limit per joint [rad/s^2 or m/s^2]."
    )
    jerk: list[float] | None = Field(
        default=None,
        description="Jerk limit per joint [rad/s^3 or m/s^3]; null where the maker publishes none.",
    )
    effort: list[float] | None = Field(
        default=None,
        description="Effort limit per joint [N m or N] (the URDF's <limit effort>, from the maker); "
        "null where none is known. Applied only when a request gives limits.effort.",
    )


class IKInfo(BaseModel):
    solver: Literal["analytic", "numeric"] = Field(
        description='"analytic": closed form (EAIK subproblems, or the planar arm\'s formula); '
        '"numeric": damped Newton from several seeds. Every solution is verified by FK to 1e-9.'
    )
    max_solutions: int | None = Field(
        description="Most distinct solutions of one pose without 2 pi turns (8 for 6R arms with a "
        "wrist, 2 for the planar arm); null where the family does not fix it."
    )
    redundant_joints: list[str] = Field(
        description="Joints IK holds at fixed_joints (else at the seed's value); empty for 6R arms."
    )


class CollisionShape(BaseModel):
    link: str = Field(description="The link the shape is fixed to.")
    shape: CapsuleShape | Sphere | Box | Cylinder = Field(
        description="The shape as the collision check uses it, in the obstacles' form [m]: a "
        "capsule (radius, length between the hemisphere centres, along the shape's z axis, "
        "centred), a sphere, a box (full edge lengths) or a cylinder (radius, length along z); "
        "an inline URDF's boxes and cylinders are exact, not wrapped in capsules."
    )
    origin: Pose = Field(description="Pose of the shape's centre in the link frame [m].")


class RobotDetail(RobotSummary):
    limits: RobotLimits
    dynamics: bool = Field(
        default=False,
        description="Inertial parameters are known (the shipped robots, from cited sources; inline "
        "URDFs with an <inertial> on every moving link): requests may give limits.effort, and "
        "diagnostics report peak_effort.",
    )
    home: list[float] = Field(description="A configuration away from singularities [rad or m].")
    limit_sources: dict[str, str] = Field(
        default_factory=dict, description="Where each kind of limit (and the home pose) comes from."
    )
    ik: IKInfo
    configurations: list[str] = Field(
        description="Every configuration label this robot's IK solutions can carry (docs/robots.md, "
        '"Configurations"); empty for robots without labels.'
    )
    collision_geometry: list[CollisionShape] = Field(
        default_factory=list,
        description="The shapes every collision check uses (place them with FK frames: true).",
    )
    allowed_self_collisions: list[list[str]] = Field(
        default_factory=list,
        description="Link pairs never checked against each other (adjacent, or never/always touching "
        "within the limits), each pair sorted, sorted.",
    )


MAX_FK_ROWS = 1000
"""Most rows of joint positions one FK request answers (``positions`` as a list of rows)."""
PositionRows = Annotated[
    list[JointPositions],
    Field(
        min_length=1,
        max_length=MAX_FK_ROWS,
        description=f"1 to {MAX_FK_ROWS} rows of joint positions [rad or m], one per joint each.",
    ),
]


def _positions_form(value: Any) -> str:
    """``rows`` for a list whose first element is a list, else ``one``: the form of ``positions``
    is chosen by its shape, so an error names the row and joint (``positions.3.1``)."""
    is_rows = isinstance(value, list) and bool(value) and isinstance(value[0], list)
    return "rows" if is_rows else "one"


class FKRequest(StrictModel):
    positions: Annotated[
        Annotated[JointPositions, Tag("one")] | Annotated[PositionRows, Tag("rows")],
        Discriminator(_positions_form),
    ] = Field(
        description="Joint positions [rad or m], one per joint, inside the limits: the answer is "
        f"one pose. Or a list of 1 to {MAX_FK_ROWS} such rows: the answer is "
        '{"results": [...]}, one single-form answer per row, in order.'
    )
    tool: Tool | None = TOOL_FIELD
    frame: str | None = FrameName
    frames: bool = Field(
        default=False,
        description="Also return every link frame's pose in kinematic order (to draw the arm).",
    )


class LinkFrame(BaseModel):
    name: str = Field(description="Link name.")
    position: list[float] = Field(description="[x, y, z] in the base frame [m].")
    orientation: list[float] = Field(description="Unit quaternion [x, y, z, w], w >= 0.")


class FKResponse(BaseModel):
    pose: Pose = Field(description="The frame's pose in the base frame.")
    jacobian: list[list[float]] = Field(
        description="6 rows x dof: geometric Jacobian in the base frame, linear rows first "
        "([m/s] per joint unit rate, then [rad/s])."
    )
    min_singular_value: float = Field(
        description="Smallest singular value of the task rows (all six for pose, x and y for "
        "position_xy); 0 at a singularity."
    )
    manipulability: float = Field(description="sqrt(det(J J^T)) over the task rows.")
    configuration: str | None = Field(
        default=None,
        description="Configuration label of the positions (docs/robots.md); null without labels.",
    )
    frames: list[LinkFrame] | None = Field(
        default=None, description='With "frames": true, every link frame in kinematic order.'
    )


class FKBatchResponse(BaseModel):
    results: list[FKResponse] = Field(
        description="One answer per row of positions, in their order: what the single form "
        "answers for that row."
    )


class IKRequest(StrictModel):
    pose: Pose
    tool: Tool | None = TOOL_FIELD
    seed: JointPositions | None = Field(
        default=None,
        description="Start of the search [rad or m] (default the robot's home); the solution nearest "
        "it is preferred. Values outside the joint limits are clipped into them.",
    )
    all: bool = Field(
        default=False,
        description="Return every distinct solution within the joint limits, nearest the seed first.",
    )
    configuration: str | None = Field(
        default=None,
        min_length=1,
        max_length=64,
        description="Only solutions with this configuration label (GET /v1/robots/{name} lists them).",
    )
    turns: bool = Field(
        default=False,
        description="With all: also every 2 pi variant of each solution within the limits.",
    )
    fixed_joints: (
        dict[Annotated[str, StringConstraints(min_length=1, max_length=256)], Position] | None
    ) = Field(
        default=None,
        max_length=64,
        description="Values [rad or m] of redundant joints to hold (default: the seed's values).",
    )


class IKResponse(BaseModel):
    positions: list[float] = Field(description="Joint positions [rad or m].")
    position_error: float = Field(
        description="Residual tip position error [m] (x, y only for position_xy)."
    )
    orientation_error: float = Field(
        description="Residual orientation error [rad] (0 for position_xy)."
    )
    configuration: str | None = Field(
        default=None, description="Configuration label of the solution; null without labels."
    )
    solver: Literal["analytic", "numeric"] | None = Field(
        default=None, description="The solver that found it."
    )
    warnings: list[str] = Field(
        default_factory=list, description="E.g. a near-singular pose (representatives returned)."
    )


class IKSolutionOut(BaseModel):
    positions: list[float] = Field(description="Joint positions [rad or m].")
    configuration: str | None = Field(description="Configuration label; null without labels.")
    position_error: float = Field(description="Tip position error [m], <= 1e-9.")
    orientation_error: float = Field(description="Orientation error [rad], <= 1e-9.")


class IKAllResponse(BaseModel):
    solutions: list[IKSolutionOut] = Field(
        description="Every distinct solution within the joint limits, nearest the seed first."
    )
    solver: Literal["analytic", "numeric"] = Field(description="The solver that found them.")
    warnings: list[str] = Field(
        default_factory=list, description="E.g. a near-singular pose (representatives returned)."
    )


class InlineFKRequest(FKRequest):
    robot: RobotRef


class InlineIKRequest(IKRequest):
    robot: RobotRef


class DescribeRequest(StrictModel):
    robot: RobotRef
    tool: Tool | None = TOOL_FIELD
