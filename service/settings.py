"""Settings from environment variables (prefix ``TRAJ_``), read once when the app is created.

The README's "Configuration" table documents every variable; keep the two in step. ``python -m
service`` takes its defaults for ``--host``, ``--port``, ``--workers`` and ``--log-level`` from here,
and a command-line flag wins over the variable.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, fields

LOG_LEVELS = ("critical", "error", "warning", "info", "debug", "trace")
LOG_FORMATS = ("json", "text")
_TRUE = ("1", "true", "yes", "on")
_FALSE = ("0", "false", "no", "off")


class SettingsError(ValueError):
    """An environment variable holds a value the service cannot use; the message names it."""


def _env(name: str, default: str) -> str:
    return os.environ.get(f"TRAJ_{name}", default).strip()


def _int(name: str, default: int, minimum: int, maximum: int | None = None) -> int:
    raw = _env(name, str(default))
    try:
        value = int(raw)
    except ValueError:
        raise SettingsError(f"TRAJ_{name} must be an integer, got {raw!r}") from None
    if value < minimum or (maximum is not None and value > maximum):
        bound = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise SettingsError(f"TRAJ_{name} must be {bound}, got {value}")
    return value


def _float(name: str, default: float) -> float:
    raw = _env(name, repr(default))
    try:
        value = float(raw)
    except ValueError:
        raise SettingsError(f"TRAJ_{name} must be a number, got {raw!r}") from None
    if not (0.0 < value < float("inf")):
        raise SettingsError(f"TRAJ_{name} must be a finite number > 0, got {raw!r}")
    return value


def _choice(name: str, default: str, choices: tuple[str, ...]) -> str:
    value = _env(name, default).lower()
    if value not in choices:
        raise SettingsError(f"TRAJ_{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


def _bool(name: str, default: bool) -> bool:
    value = _env(name, "true" if default else "false").lower()
    if value in _TRUE:
        return True
    if value in _FALSE:
        return False
    raise SettingsError(f"TRAJ_{name} must be true or false, got {value!r}")


@dataclass(frozen=True)
class Settings:
    """Service limits, budgets and process options.

    Attributes:
        max_body_bytes: Largest request body accepted in [bytes]; larger is 413 (default 2 MiB).
        max_points: Most points in one trajectory response.
        time_budget_s: Wall-time budget of one planning request in [s].
        log_level: Log level of the application and uvicorn (one of ``LOG_LEVELS``).
        urdf_cache_size: Parsed client URDF models kept (LRU, keyed by content hash).
        workers: uvicorn worker processes started by ``python -m service``.
        host: Bind address of ``python -m service``.
        port: TCP port of ``python -m service``.
        log_format: ``json`` (one object per line) or ``text`` (for a terminal).
        access_log: One log line per request (method, route, status, duration).
    """

    max_body_bytes: int = 2 * 1024 * 1024
    max_points: int = 100_000
    time_budget_s: float = 10.0
    log_level: str = "info"
    urdf_cache_size: int = 32
    workers: int = 1
    host: str = "127.0.0.1"
    port: int = 8000
    log_format: str = "json"
    access_log: bool = True

    @classmethod
    def from_env(cls) -> Settings:
        """Read every ``TRAJ_*`` variable; a malformed one raises ``SettingsError`` naming it."""
        return cls(
            max_body_bytes=_int("MAX_BODY_BYTES", cls.max_body_bytes, 1),
            max_points=_int("MAX_POINTS", cls.max_points, 2),
            time_budget_s=_float("TIME_BUDGET_S", cls.time_budget_s),
            log_level=_choice("LOG_LEVEL", cls.log_level, LOG_LEVELS),
            urdf_cache_size=_int("URDF_CACHE_SIZE", cls.urdf_cache_size, 0),
            workers=_int("WORKERS", cls.workers, 1, 256),
            host=_env("HOST", cls.host) or cls.host,
            port=_int("PORT", cls.port, 0, 65535),
            log_format=_choice("LOG_FORMAT", cls.log_format, LOG_FORMATS),
            access_log=_bool("ACCESS_LOG", cls.access_log),
        )


def env_names() -> list[str]:
    """Every environment variable the service reads, in field order (``TRAJ_MAX_BODY_BYTES``...)."""
    return [f"TRAJ_{f.name.upper()}" for f in fields(Settings)]
