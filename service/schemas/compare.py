"""Request and response of POST /v1/compare: one Cartesian task through several methods."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from service.schemas.cartesian import CartesianTaskSpec, Method
from service.schemas.common import Problem


class CompareRequest(BaseModel):
    """POST /v1/compare."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)

    task: CartesianTaskSpec = Field(
        description="A Cartesian request without `method` (same fields, units and bounds)."
    )
    methods: list[Method] | None = Field(
        default=None,
        min_length=1,
        max_length=5,
        description="Methods to run, each at most once (default: all five, in API.md order).",
    )
    include_trajectories: bool = Field(
        default=False, description="Add each successful method's trajectory to its row."
    )

    @field_validator("methods")
    @classmethod
    def _unique(cls, methods: list[str] | None) -> list[str] | None:
        if methods is not None and len(set(methods)) != len(methods):
            raise ValueError("each method may be named once")
        return methods


class CompareRow(BaseModel):
    model_config = ConfigDict(extra="allow")

    method: str = Field(description="The method of this row.")
    ok: bool = Field(description="Whether the method planned the task.")
    error: Problem | None = Field(
        default=None, description="The method's problem+json when it failed."
    )
    diagnostics: dict[str, Any] = Field(
        description="The method's diagnostics (as in the Cartesian endpoint), or the failure's."
    )
    trajectory: dict[str, Any] | None = Field(
        default=None, description="joint_names, points (and knots) when include_trajectories."
    )


class CompareResponse(BaseModel):
    results: list[CompareRow] = Field(description="One row per method, in the order requested.")
