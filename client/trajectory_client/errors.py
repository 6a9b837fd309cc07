"""The service's problem+json answers (RFC 9457) as exceptions, one class per family.

Every answer that is not a success raises a ``ServiceError`` carrying the whole problem body and its
usual keys as attributes (``status``, ``code``, ``detail``, ``s``, ``segment``, ``errors``); branch
on the class or on ``code``, never on ``detail``. A service that cannot be reached (after the
retries) raises ``TransportError``. Both derive from ``TrajectoryError``.
"""

from __future__ import annotations

from typing import Any

INVALID_REQUEST_CODES = frozenset(
    {
        "validation",
        "invalid_urdf",
        "too_large",
        "unsupported_media_type",
        "bad_request",
        "method_not_allowed",
    }
)
"""Codes of a request the service cannot take as sent (whatever the status: 400, 405, 413, 415,
422): fix the request, do not retry it."""


class TrajectoryError(Exception):
    """Base of everything this client raises."""


class TransportError(TrajectoryError):
    """No answer from the service: the connection refused or reset after every retry, or a
    timeout (never retried: the service is busy with the request). The httpx error is chained as
    ``__cause__``."""


class ServiceError(TrajectoryError):
    """An answer that is not a success.

    Attributes:
        status: The HTTP status.
        code: The problem's ``code`` (``unreachable``, ``validation``, ...), None when the body is
            not problem+json (a proxy's error page).
        title: Its short summary.
        detail: Its one-sentence explanation.
        s: Path parameter in [0, 1] where a Cartesian or program plan failed, else None.
        segment: Index of a program's failing segment, else None.
        errors: Each field at fault (``[{"loc": [...], "msg": ...}]``) for validation failures.
        retry_after: Seconds the service asked to wait (``Retry-After``), else None.
        body: The whole problem document (every extra key: ``links``, ``min_duration``, ...).
    """

    def __init__(self, status: int, body: dict[str, Any], retry_after: float | None = None):
        self.status = status
        self.body = body
        self.code: str | None = body.get("code")
        self.title: str = str(body.get("title", ""))
        self.detail: str = str(body.get("detail", ""))
        self.s: float | None = body.get("s")
        self.segment: int | None = body.get("segment")
        self.errors: list[dict[str, Any]] = list(body.get("errors") or [])
        self.retry_after = retry_after
        super().__init__(f"{status} {self.code or 'error'}: {self.detail or self.title}")


class InvalidRequest(ServiceError):
    """The request is malformed or asks for too much (``validation``, ``invalid_urdf``,
    ``too_large``, ...): ``errors`` names the fields."""


class NotFound(ServiceError):
    """404: an unknown robot (``available`` in ``body`` lists the names), frame or path."""


class PlanningFailed(ServiceError):
    """422: a well-formed request the service could not plan (``unreachable``, ``joint_limit``,
    ``collision``, ``time_budget_exceeded``, ...), with ``s`` and ``segment`` when known."""


class Unavailable(ServiceError):
    """503: the service cannot answer now."""


class Overloaded(Unavailable):
    """503 ``overloaded``, still after every retry (``retry_after`` says how long to wait)."""


class NotReady(Unavailable):
    """503 ``not_ready``: the service has not finished starting."""


class ServerError(ServiceError):
    """5xx other than 503: a defect of the service (``internal_error``)."""


def error_for(status: int, body: Any, retry_after: float | None = None) -> ServiceError:
    """The exception for an answer of ``status`` with the decoded ``body`` (anything: a body that
    is not a JSON object becomes ``{"detail": <text>}``)."""
    if not isinstance(body, dict):
        body = {"detail": str(body)[:500]}
    code = body.get("code")
    cls: type[ServiceError]
    if status == 404:
        cls = NotFound
    elif code in INVALID_REQUEST_CODES:
        cls = InvalidRequest
    elif status == 422:
        cls = PlanningFailed
    elif status == 503:
        cls = {"overloaded": Overloaded, "not_ready": NotReady}.get(str(code), Unavailable)
    elif status >= 500:
        cls = ServerError
    elif status in (400, 405, 413, 415):
        cls = InvalidRequest
    else:
        cls = ServiceError
    return cls(status, body, retry_after)
