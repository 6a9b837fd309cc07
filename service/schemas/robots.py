"""Request and response models of /v1/robots (units and bounds in every Field)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from service.schemas.common import JointPositions, Pose, StrictModel

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


class RobotDetail(RobotSummary):
    limits: RobotLimits
    home: list[float] = Field(description="A configuration away from singularities [rad or m].")
    limit_sources: dict[str, str] = Field(
        default_factory=dict, description="Where each kind of limit (and the home pose) comes from."
    )


class FKRequest(StrictModel):
    positions: JointPositions
    frame: str | None = FrameName


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


class IKRequest(StrictModel):
    pose: Pose
    seed: JointPositions | None = Field(
        default=None,
        description="Start of the search [rad or m] (default the robot's home); the solution nearest "
        "it is preferred. Values outside the joint limits are clipped into them.",
    )


class IKResponse(BaseModel):
    positions: list[float] = Field(description="Joint positions [rad or m].")
    position_error: float = Field(
        description="Residual tip position error [m] (x, y only for position_xy)."
    )
    orientation_error: float = Field(
        description="Residual orientation error [rad] (0 for position_xy)."
    )
