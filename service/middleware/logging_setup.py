"""Structured logs: one JSON object per line, each carrying the id of the request it belongs to.

``REQUEST_ID`` is a context variable set by the observability middleware for the duration of a
request; starlette copies the context into the thread pool that runs ``def`` routes, so every line
logged while a request is served (by our code, core, robots or uvicorn) carries its id. A line has
``ts`` (UTC, ISO 8601, ms), ``level``, ``logger``, ``msg``, ``request_id`` when there is one, and any
``extra=`` fields (access lines add ``method``, ``route``, ``path``, ``status``, ``duration_ms``).

This module imports nothing heavy: ``python -m service`` uses it in the supervisor process, which must
not import prometheus_client before ``PROMETHEUS_MULTIPROC_DIR`` is set.
"""

from __future__ import annotations

import logging
import re
import time
import uuid
from contextvars import ContextVar
from typing import Any

import orjson

REQUEST_ID: ContextVar[str | None] = ContextVar("request_id", default=None)
REQUEST_ID_HEADER = "X-Request-ID"
_VALID_REQUEST_ID = re.compile(r"[A-Za-z0-9._-]{1,128}")

# Attributes every LogRecord has; anything else on a record came from ``extra=`` and is emitted.
_STANDARD = frozenset(
    logging.LogRecord("", 0, "", 0, "", (), None).__dict__.keys()
    | {"message", "asctime", "color_message", "request_id", "taskName"}
)


def request_id_from(value: str | bytes | None) -> str:
    """The client's ``X-Request-ID`` if it is 1-128 chars of ``[A-Za-z0-9._-]``, else a new uuid4 hex."""
    if value is not None:
        text = value.decode("latin-1") if isinstance(value, bytes) else value
        if _VALID_REQUEST_ID.fullmatch(text):
            return text
    return uuid.uuid4().hex


def _timestamp(created: float) -> str:
    whole = int(created)
    return (
        time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(whole))
        + f".{int((created - whole) * 1000):03d}Z"
    )


class JsonFormatter(logging.Formatter):
    """One compact JSON object per record (orjson; values it cannot encode become strings)."""

    def format(self, record: logging.LogRecord) -> str:
        doc: dict[str, Any] = {
            "ts": _timestamp(record.created),
            "level": record.levelname.lower(),
            "logger": record.name,
            "msg": record.getMessage(),
        }
        request_id = getattr(record, "request_id", None) or REQUEST_ID.get()
        if request_id is not None:
            doc["request_id"] = request_id
        for key, value in record.__dict__.items():
            if key not in _STANDARD and key not in doc:
                doc[key] = value
        if record.exc_info:
            doc["exc"] = self.formatException(record.exc_info)
        if record.stack_info:
            doc["stack"] = self.formatStack(record.stack_info)
        return orjson.dumps(doc, default=str, option=orjson.OPT_SERIALIZE_NUMPY).decode()


class TextFormatter(logging.Formatter):
    """Human-readable lines for a terminal: ``ts level logger [request_id] msg key=value...``."""

    def format(self, record: logging.LogRecord) -> str:
        request_id = getattr(record, "request_id", None) or REQUEST_ID.get() or "-"
        extras = " ".join(f"{k}={v}" for k, v in record.__dict__.items() if k not in _STANDARD)
        line = (
            f"{_timestamp(record.created)} {record.levelname.lower():<7} {record.name} "
            f"[{request_id}] {record.getMessage()}"
        )
        if extras:
            line += " " + extras
        if record.exc_info:
            line += "\n" + self.formatException(record.exc_info)
        return line


def log_config(level: str = "info", fmt: str = "json") -> dict[str, Any]:
    """A ``logging.config.dictConfig`` dict for uvicorn's ``log_config``: every logger, one handler.

    Args:
        level: One of ``service.settings.LOG_LEVELS`` (``trace`` is uvicorn's level 5).
        fmt: ``json`` or ``text``.
    """
    level_name = "TRACE" if level.lower() == "trace" else level.upper()
    formatter = JsonFormatter if fmt == "json" else TextFormatter
    handler = {
        "class": "logging.StreamHandler",
        "formatter": "default",
        "stream": "ext://sys.stdout",
    }
    own = {"handlers": ["default"], "level": level_name, "propagate": False}
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "formatters": {"default": {"()": f"{formatter.__module__}.{formatter.__qualname__}"}},
        "handlers": {"default": handler},
        "loggers": {
            "uvicorn": own,
            "uvicorn.error": {"level": level_name, "propagate": True},
            "uvicorn.access": own,
        },
        "root": {"handlers": ["default"], "level": level_name},
    }
