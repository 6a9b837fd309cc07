"""The ``environment`` of a trajectory request: obstacles, clearance, self-collision, allowed pairs.

Every size is bounded (``MIN_SIZE`` to ``MAX_SIZE``); names are unique; a halfspace normal must be unit to 1e-3
(then normalized) and has no pose; at most ``MAX_OBSTACLES`` obstacles. Names that must match the
robot (allowed pairs, obstacle names that clash with link names) are checked in
``service/convert/environment.py``, which knows the robot.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from service.schemas.common import Pose, Position, StrictModel

MAX_OBSTACLES = 256
MAX_SIZE = 100.0
"""Largest obstacle dimension [m]."""
MIN_SIZE = 1e-6
"""Smallest obstacle dimension [m]: a micrometre. coal answers a cylinder of radius 1e-9 m and
length 99 m with a distance of -1.8e308 and NaN points; down to 1e-6 m every shape measures."""
MAX_CLEARANCE = 10.0
"""Largest clearance [m]."""
MAX_ALLOWED_PAIRS = 4096
NORMAL_TOLERANCE = 1e-3

Size = Annotated[float, Field(ge=MIN_SIZE, le=MAX_SIZE)]
Name = Annotated[str, Field(min_length=1, max_length=128)]


class Box(StrictModel):
    type: Literal["box"]
    size: list[Size] = Field(
        min_length=3, max_length=3, description="Full edge lengths [x, y, z] [m], each 1e-6 to 100."
    )


class Sphere(StrictModel):
    type: Literal["sphere"]
    radius: Size = Field(description="Radius [m] 1e-6 to 100.")


class Cylinder(StrictModel):
    type: Literal["cylinder"]
    radius: Size = Field(description="Radius [m] 1e-6 to 100.")
    length: Size = Field(description="Length along the local z axis [m], centred, 1e-6 to 100.")


class CapsuleShape(StrictModel):
    type: Literal["capsule"]
    radius: Size = Field(description="Radius [m] 1e-6 to 100.")
    length: Size = Field(
        description="Distance between the two hemisphere centres along local z [m] (as in coal)."
    )


class Halfspace(StrictModel):
    type: Literal["halfspace"]
    normal: list[Annotated[float, Field(ge=-1.001, le=1.001)]] = Field(
        min_length=3,
        max_length=3,
        description="Unit normal (within 1e-3, then normalized); solid where normal . x <= offset.",
    )
    offset: Position = Field(description="[m]: the solid side is normal . x <= offset.")

    @field_validator("normal")
    @classmethod
    def _unit(cls, n: list[float]) -> list[float]:
        norm = math.sqrt(sum(v * v for v in n))
        if abs(norm - 1.0) > NORMAL_TOLERANCE:
            raise ValueError("the halfspace normal must have norm 1 (within 1e-3)")
        return [v / norm for v in n]


Shape = Annotated[Box | Sphere | Cylinder | CapsuleShape | Halfspace, Field(discriminator="type")]


class ObstacleSpec(StrictModel):
    """One obstacle in the robot's base frame."""

    name: Name = Field(description="Unique; not a link name of the robot.")
    shape: Shape
    pose: Pose | None = Field(
        default=None,
        description="Pose of the shape's centre in the base frame (default identity); none for a "
        "halfspace.",
    )

    @model_validator(mode="after")
    def _halfspace_has_no_pose(self) -> ObstacleSpec:
        if isinstance(self.shape, Halfspace) and self.pose is not None:
            raise ValueError("a halfspace has no pose (its normal and offset place it)")
        return self


class Environment(StrictModel):
    """The work cell: checked continuously along every returned trajectory."""

    obstacles: list[ObstacleSpec] = Field(
        default_factory=list, max_length=MAX_OBSTACLES, description="At most 256 obstacles."
    )
    clearance: float = Field(
        default=0.0,
        ge=0.0,
        le=MAX_CLEARANCE,
        description="[m] in [0, 10]: no robot geometry may come closer than this to an obstacle.",
    )
    self_collision: bool = Field(default=True, description="Check the robot against itself.")
    allowed_collisions: list[Annotated[list[Name], Field(min_length=2, max_length=2)]] = Field(
        default_factory=list,
        max_length=MAX_ALLOWED_PAIRS,
        description="Pairs of names (link/link or link/obstacle) that are never checked.",
    )

    @field_validator("obstacles")
    @classmethod
    def _unique_names(cls, obstacles: list[ObstacleSpec]) -> list[ObstacleSpec]:
        seen: set[str] = set()
        for o in obstacles:
            if o.name in seen:
                raise ValueError("obstacle names must be unique")
            seen.add(o.name)
        return obstacles
