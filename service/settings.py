"""Settings from environment variables (prefix ``TRAJ_``), read once when the app is created."""

from __future__ import annotations

import os
from dataclasses import dataclass


def _env(name: str, default: str) -> str:
    return os.environ.get(f"TRAJ_{name}", default)


@dataclass(frozen=True)
class Settings:
    """Service limits and budgets.

    Attributes:
        max_body_bytes: Largest request body accepted; larger is 413 (default 2 MiB).
        max_points: Most points in one trajectory response.
        time_budget_s: Wall-time budget of one planning request in [s].
        log_level: uvicorn/application log level.
        urdf_cache_size: Parsed client URDF models kept (LRU, keyed by content hash).
    """

    max_body_bytes: int = 2 * 1024 * 1024
    max_points: int = 100_000
    time_budget_s: float = 10.0
    log_level: str = "info"
    urdf_cache_size: int = 32

    @classmethod
    def from_env(cls) -> Settings:
        return cls(
            max_body_bytes=int(_env("MAX_BODY_BYTES", str(cls.max_body_bytes))),
            max_points=int(_env("MAX_POINTS", str(cls.max_points))),
            time_budget_s=float(_env("TIME_BUDGET_S", str(cls.time_budget_s))),
            log_level=_env("LOG_LEVEL", cls.log_level),
            urdf_cache_size=int(_env("URDF_CACHE_SIZE", str(cls.urdf_cache_size))),
        )
