"""How each endpoint's answer is read: endpoint (its path after ``/v1/``) -> ``(json, as_numpy) ->
result``. The typed methods and batch items use the same table; a new endpoint is one line."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from trajectory_client.results import Comparison, Distance, FKResult, IKResult, Trajectory

PARSERS: dict[str, Callable[[dict[str, Any], bool], Any]] = {
    "fk": FKResult.from_json,
    "ik": IKResult.from_json,
    "distance": Distance.from_json,
    "trajectories/joint": Trajectory.from_json,
    "trajectories/spline": Trajectory.from_json,
    "trajectories/cartesian": Trajectory.from_json,
    "trajectories/program": Trajectory.from_json,
    "trajectories/retime": Trajectory.from_json,
    "trajectories/collision_free": Trajectory.from_json,
    "compare": Comparison.from_json,
}


def parse(endpoint: str, doc: dict[str, Any], as_numpy: bool = False) -> Any:
    """The typed result of ``endpoint``'s answer ``doc`` (the plain dict for an endpoint this
    client does not know yet)."""
    reader = PARSERS.get(endpoint)
    return doc if reader is None else reader(doc, as_numpy)
