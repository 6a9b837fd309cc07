"""Settings from environment variables (prefix ``TRAJ_``), read once when the app is created.

``Settings`` is a pydantic-settings ``BaseSettings``: every field is read from the variable
``TRAJ_<FIELD NAME IN UPPER CASE>`` (``TRAJ_MAX_BODY_BYTES``, ``TRAJ_TIME_BUDGET_S``...), falling
back to the default below; a keyword argument wins over the variable (``Settings(max_points=10)``).
``Settings.from_env()`` turns a malformed variable into ``SettingsError`` naming it. The README's
"Configuration" table documents every variable (``env_names()`` lists them); keep the two in step.
``python -m service`` takes its defaults for ``--host``, ``--port``, ``--workers`` and
``--log-level`` from here, and a command-line flag wins over the variable.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field, ValidationError, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

LOG_LEVELS = ("critical", "error", "warning", "info", "debug", "trace")
LOG_FORMATS = ("json", "text")
ENV_PREFIX = "TRAJ_"


class SettingsError(ValueError):
    """An environment variable holds a value the service cannot use; the message names it."""


class Settings(BaseSettings):
    """Service limits, budgets and process options, each from ``TRAJ_<NAME>``.

    Attributes:
        max_body_bytes: Largest request body accepted in [bytes]; larger is 413 (default 2 MiB).
        max_points: Most points in one trajectory response.
        time_budget_s: Wall-time budget of one request in [s] (planning and encoding).
        log_level: Log level of the application and uvicorn (one of ``LOG_LEVELS``).
        urdf_cache_size: Parsed client URDF models kept (LRU, keyed by content hash).
        workers: uvicorn worker processes started by ``python -m service``.
        host: Bind address of ``python -m service``.
        port: TCP port of ``python -m service``.
        log_format: ``json`` (one object per line) or ``text`` (for a terminal).
        access_log: One log line per request (method, route, status, duration).
        max_response_bytes: Largest estimated trajectory response in [bytes] (points x joints x
            bytes per number); larger is 422 ``too_large`` before encoding (default 512 MiB).
        response_budget_bytes: Estimated bytes of responses one worker holds in flight at once in
            [bytes]; a response that would exceed it while others are in flight is 503
            ``overloaded`` with ``Retry-After`` (default 768 MiB).
        memory_budget_bytes: Estimated working memory of the requests one worker runs at once in
            [bytes] (planning arrays, samples x joints, and collision-check entries, points x pairs:
            ``service.admission``); a request that would exceed it while others run is 503
            ``overloaded`` with ``Retry-After`` (default 1 GiB).
        header_timeout_s: Time a client has to send a request's line and headers in [s], counted
            from its first byte; past it, 408 ``request_timeout`` and the connection is closed.
        body_timeout_s: Longest wait for the next piece of a request body in [s]; past it, 408.
        body_deadline_s: Longest time for a whole request body in [s], counted from the end of its
            headers; past it, 408 and the connection is closed (a body trickled a byte at a time
            never stalls for ``body_timeout_s``).
        write_timeout_s: Longest wait for a client to accept the next piece of a response in [s];
            past it the connection is closed (a client that does not read cannot pin memory).
        keep_alive_timeout_s: Idle time after which a keep-alive connection is closed in [s].
        max_connections: Open connections plus running requests per worker (uvicorn's
            ``limit_concurrency``); more is 503 ``overloaded``.
        malloc_retain_bytes: Freed memory a worker keeps for reuse in [bytes] (glibc ``malloc``
            tuning, ``service.allocator``); 0 leaves glibc's defaults.
        batch_budget_s: Wall-time budget of one ``POST /v1/batch`` in [s]: an item not started
            by then answers 422 ``time_budget_exceeded``, and a running item stops no later.
    """

    model_config = SettingsConfigDict(env_prefix=ENV_PREFIX, frozen=True, extra="forbid")

    max_body_bytes: int = Field(default=2 * 1024 * 1024, ge=1)
    max_points: int = Field(default=100_000, ge=2)
    time_budget_s: float = Field(default=10.0, gt=0, allow_inf_nan=False)
    log_level: str = "info"
    urdf_cache_size: int = Field(default=32, ge=0)
    workers: int = Field(default=1, ge=1, le=256)
    host: str = "127.0.0.1"
    port: int = Field(default=8000, ge=0, le=65535)
    log_format: str = "json"
    access_log: bool = True
    max_response_bytes: int = Field(default=512 * 1024 * 1024, ge=1024)
    response_budget_bytes: int = Field(default=768 * 1024 * 1024, ge=1024)
    memory_budget_bytes: int = Field(default=1024 * 1024 * 1024, ge=1024 * 1024)
    header_timeout_s: float = Field(default=10.0, gt=0, allow_inf_nan=False)
    body_timeout_s: float = Field(default=10.0, gt=0, allow_inf_nan=False)
    body_deadline_s: float = Field(default=30.0, gt=0, allow_inf_nan=False)
    write_timeout_s: float = Field(default=30.0, gt=0, allow_inf_nan=False)
    keep_alive_timeout_s: float = Field(default=5.0, gt=0, allow_inf_nan=False)
    max_connections: int = Field(default=1000, ge=1)
    malloc_retain_bytes: int = Field(default=32 * 1024 * 1024, ge=0, le=1024 * 1024 * 1024)
    batch_budget_s: float = Field(default=60.0, gt=0, allow_inf_nan=False)

    @field_validator("log_level", "log_format", mode="before")
    @classmethod
    def _lower(cls, value: Any) -> Any:
        return value.strip().lower() if isinstance(value, str) else value

    @field_validator("log_level")
    @classmethod
    def _log_level(cls, value: str) -> str:
        if value not in LOG_LEVELS:
            raise ValueError(f"must be one of {', '.join(LOG_LEVELS)}")
        return value

    @field_validator("log_format")
    @classmethod
    def _log_format(cls, value: str) -> str:
        if value not in LOG_FORMATS:
            raise ValueError(f"must be one of {', '.join(LOG_FORMATS)}")
        return value

    @field_validator("host", mode="before")
    @classmethod
    def _host(cls, value: Any) -> Any:
        return (value.strip() or "127.0.0.1") if isinstance(value, str) else value

    @classmethod
    def from_env(cls) -> Settings:
        """Read every ``TRAJ_*`` variable; a malformed one raises ``SettingsError`` naming it."""
        try:
            return cls()
        except ValidationError as e:
            first = e.errors()[0]
            name = ENV_PREFIX + str(first["loc"][0]).upper() if first["loc"] else ENV_PREFIX
            raise SettingsError(f"{name}: {first['msg']}") from None


def env_names() -> list[str]:
    """Every environment variable the service reads, in field order (``TRAJ_MAX_BODY_BYTES``...)."""
    return [ENV_PREFIX + name.upper() for name in Settings.model_fields]
