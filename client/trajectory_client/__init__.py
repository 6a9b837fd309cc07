"""A typed Python client for the Trajectory Service HTTP API.

from trajectory_client import TrajectoryClient

with TrajectoryClient("http://127.0.0.1:8000") as client:
    plan = client.joint(profile="quintic", start={"positions": [0, 0]},
                        goal={"positions": [1, 0.5]}, as_numpy=True)
    print(plan.duration, plan.positions.shape)
"""

from __future__ import annotations

__version__ = "0.1.0"

from trajectory_client.batch import BatchItem, BatchStream
from trajectory_client.client import DEFAULT_URL, TrajectoryClient
from trajectory_client.errors import (
    InvalidRequest,
    NotFound,
    NotReady,
    Overloaded,
    PlanningFailed,
    ServerError,
    ServiceError,
    TrajectoryError,
    TransportError,
    Unavailable,
)
from trajectory_client.results import (
    BatchResult,
    CompareRow,
    Comparison,
    Distance,
    FKResult,
    Health,
    IKResult,
    IKSolution,
    Pose,
    Ready,
    Robot,
    Trajectory,
)
from trajectory_client.retry import NO_RETRY, RetryPolicy

__all__ = [
    "DEFAULT_URL",
    "NO_RETRY",
    "BatchItem",
    "BatchResult",
    "BatchStream",
    "CompareRow",
    "Comparison",
    "Distance",
    "FKResult",
    "Health",
    "IKResult",
    "IKSolution",
    "InvalidRequest",
    "NotFound",
    "NotReady",
    "Overloaded",
    "PlanningFailed",
    "Pose",
    "Ready",
    "RetryPolicy",
    "Robot",
    "ServerError",
    "ServiceError",
    "Trajectory",
    "TrajectoryClient",
    "TrajectoryError",
    "TransportError",
    "Unavailable",
    "__version__",
]
