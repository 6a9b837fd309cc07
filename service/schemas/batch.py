"""``POST /v1/batch``: the envelope of a batch and of its answer (each item's body is its endpoint's)."""

from __future__ import annotations

from typing import Any, Literal

from fastapi import Query
from pydantic import BaseModel, ConfigDict, Field, field_validator

from service.batch.endpoints import ENDPOINTS
from service.schemas.common import StrictModel

MAX_ITEMS = 256
"""Most items in one batch."""
STREAM_MEDIA_TYPE = "application/x-ndjson"
Stream = Literal["ndjson"]
STREAM_QUERY: Any = Query(
    None,
    description="`ndjson`: answer one JSON line per item as soon as it is done "
    f'(`{STREAM_MEDIA_TYPE}`), then a last line `{{"summary": {{...}}}}`; absent: one JSON '
    "document once every item is done.",
)


class BatchItem(StrictModel):
    """One request of the batch."""

    endpoint: str = Field(
        description="The endpoint that answers the item: its path after `/v1/`.",
        json_schema_extra={"enum": list(ENDPOINTS)},
    )
    body: dict[str, Any] = Field(
        description="The endpoint's request body, exactly as it would be POSTed to "
        "`/v1/<endpoint>` (validated by that endpoint's schema when the item runs: a malformed "
        "body fails its item, not the batch)."
    )

    @field_validator("endpoint")
    @classmethod
    def _known(cls, value: str) -> str:
        if value not in ENDPOINTS:
            raise ValueError(f"must be one of {', '.join(ENDPOINTS)}")
        return value


EXAMPLE: dict[str, Any] = {
    "defaults": {"robot": "ur5"},
    "items": [
        {
            "endpoint": "trajectories/joint",
            "body": {
                "profile": "quintic",
                "start": {"positions": [0.0, -1.047, 1.571, -2.094, -1.571, 0.0]},
                "goal": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]},
            },
        },
        {"endpoint": "fk", "body": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]}},
    ],
}


class BatchRequest(StrictModel):
    """Up to 256 plan requests, answered in order, each as its endpoint answers it."""

    model_config = ConfigDict(json_schema_extra={"examples": [EXAMPLE]})

    items: list[BatchItem] = Field(
        min_length=1, max_length=MAX_ITEMS, description="The requests, at most 256."
    )
    defaults: dict[str, Any] = Field(
        default_factory=dict,
        description="Top-level fields given to every item whose body does not set them and "
        "whose endpoint takes them (`robot`, `environment`, `sample_period` ...): send a large "
        "inline URDF or environment once. A key no item's endpoint takes is 422.",
    )


class BatchItemResult(BaseModel):
    index: int = Field(description="Position of the item in `items` (0-based).")
    endpoint: str = Field(description="The item's endpoint.")
    status: int = Field(description="The HTTP status its endpoint answered (200, 404, 422 ...).")
    body: dict[str, Any] = Field(
        description="Its endpoint's answer: the result, or the problem+json of its failure."
    )


class BatchSummary(BaseModel):
    items: int = Field(description="Items in the batch.")
    succeeded: int = Field(description="Items answered 2xx.")
    failed: int = Field(description="Items answered otherwise (not started ones included).")
    not_started: int = Field(description="Items the time budget left unstarted.")
    compute_time_ms: float = Field(description="Wall time of the batch [ms].")
    budget_s: float = Field(description="The batch's wall-time budget [s].")
    shared: dict[str, dict[str, int]] = Field(
        description="Per shared model kind (`robot`, `collision_model`): how many were built "
        "and how many calls reused one."
    )


class BatchResponse(BaseModel):
    results: list[BatchItemResult] = Field(description="One per item, in the order of `items`.")
    summary: BatchSummary
