"""The endpoints a batch item may name: the item's ``endpoint`` -> the route that answers it.

An item is answered by the route itself (``service.batch.subrequest``): its schema validates the
item's body, its code plans it and its error table words a failure, so an item's answer is the
answer the endpoint gives to the same body. A new endpoint joins batches with one line here.
"""

from __future__ import annotations

from typing import NamedTuple

from pydantic import BaseModel

from service.routes.collision import InlineDistanceRequest
from service.schemas.cartesian import CartesianRequest
from service.schemas.collision_free import CollisionFreeRequest
from service.schemas.compare import CompareRequest
from service.schemas.program import ProgramRequest
from service.schemas.retime import RetimeRequest
from service.schemas.robots import InlineFKRequest, InlineIKRequest
from service.schemas.trajectories import JointTrajectoryRequest, SplineRequest


class Endpoint(NamedTuple):
    """path: the POST route that answers the item; body: its request model (the top-level fields
    a batch's ``defaults`` may fill)."""

    path: str
    body: type[BaseModel]


ENDPOINTS: dict[str, Endpoint] = {
    "fk": Endpoint("/v1/fk", InlineFKRequest),
    "ik": Endpoint("/v1/ik", InlineIKRequest),
    "distance": Endpoint("/v1/distance", InlineDistanceRequest),
    "trajectories/joint": Endpoint("/v1/trajectories/joint", JointTrajectoryRequest),
    "trajectories/spline": Endpoint("/v1/trajectories/spline", SplineRequest),
    "trajectories/cartesian": Endpoint("/v1/trajectories/cartesian", CartesianRequest),
    "trajectories/program": Endpoint("/v1/trajectories/program", ProgramRequest),
    "compare": Endpoint("/v1/compare", CompareRequest),
    "trajectories/retime": Endpoint("/v1/trajectories/retime", RetimeRequest),
    "trajectories/collision_free": Endpoint(
        "/v1/trajectories/collision_free", CollisionFreeRequest
    ),
}
"""Item ``endpoint`` -> its route (every one takes its robot in the body: no path parameters)."""


def body_fields(endpoint: str) -> frozenset[str]:
    """The top-level fields of ``endpoint``'s request body."""
    return frozenset(ENDPOINTS[endpoint].body.model_fields)
