"""The problem+json document (RFC 9457) every error answer carries, as a dict or as bytes.

Light on imports (orjson only): the HTTP protocol (``service.middleware.http_protocol``) writes these
bodies before a request reaches the app, in a process that must not import the app yet.
"""

from __future__ import annotations

from typing import Any

import orjson

PROBLEM_TYPE_BASE = "https://trajectory-service/errors/"
PROBLEM_MEDIA_TYPE = "application/problem+json"


def problem_body(status: int, code: str, title: str, detail: str, **extra: Any) -> dict[str, Any]:
    """The problem+json document as a dict (``None`` values dropped)."""
    body: dict[str, Any] = {
        "type": PROBLEM_TYPE_BASE + code,
        "title": title,
        "status": status,
        "detail": detail,
        "code": code,
    }
    body.update({k: v for k, v in extra.items() if v is not None})
    return body


def problem_bytes(status: int, code: str, title: str, detail: str, **extra: Any) -> bytes:
    """``problem_body(...)`` encoded as JSON."""
    return orjson.dumps(
        problem_body(status, code, title, detail, **extra), option=orjson.OPT_SERIALIZE_NUMPY
    )
