"""One table: core/robots exceptions -> HTTP status + ``application/problem+json`` (RFC 9457) body.

Every error the service answers has ``type``, ``title``, ``status``, ``detail`` and ``code``; Cartesian
failures add ``s`` (path parameter in [0, 1]); validation failures add ``errors`` with each field's
location and a message. No body ever echoes the offending input value back.
"""

from __future__ import annotations

import logging
from typing import Any

import orjson
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import Response

from core import errors as ex
from service import metrics

log = logging.getLogger("service.errors")

PROBLEM_TYPE_BASE = "https://trajectory-service/errors/"
PROBLEM_MEDIA_TYPE = "application/problem+json"

STATUS: dict[type[ex.PlanningError], int] = {
    ex.InputError: 422,
    ex.UnknownRobot: 404,
    ex.UnknownFrame: 404,
    ex.InvalidURDF: 422,
    ex.Unreachable: 422,
    ex.JointLimit: 422,
    ex.BranchFlip: 422,
    ex.Singularity: 422,
    ex.JointRateLimit: 422,
    ex.Infeasible: 422,
    ex.NoConvergence: 422,
    ex.TooLarge: 422,
    ex.TimeBudgetExceeded: 422,
    ex.Collision: 422,
}


def _finite_or_none(value: Any) -> Any:
    try:
        f = float(value)
    except (TypeError, ValueError):
        return value
    return f if f == f and abs(f) != float("inf") else None


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


def problem_response(status: int, body: dict[str, Any]) -> Response:
    return Response(
        orjson.dumps(body, option=orjson.OPT_SERIALIZE_NUMPY),
        status_code=status,
        media_type=PROBLEM_MEDIA_TYPE,
    )


def planning_error_body(err: ex.PlanningError) -> tuple[int, dict[str, Any]]:
    """Status and problem body of a core/robots error (also used inside /v1/compare rows)."""
    status = next((code for cls, code in STATUS.items() if isinstance(err, cls)), 422)
    extra: dict[str, Any] = {
        "s": None if err.s is None else _finite_or_none(round(float(err.s), 6)),
        "joint": err.joint,
        "sample": err.sample,
    }
    if err.field is not None:
        extra["errors"] = [{"loc": ["body", *err.field], "msg": err.detail}]
    extra.update({k: _finite_or_none(v) for k, v in err.extra.items()})
    return status, problem_body(status, err.code, err.title, err.detail, **extra)


def _validation_errors(exc: RequestValidationError) -> list[dict[str, Any]]:
    out = []
    for e in exc.errors():
        loc = [p if isinstance(p, int | str) else str(p) for p in e.get("loc", ())]
        msg = str(e.get("msg", "invalid value"))
        out.append({"loc": loc, "msg": msg, "type": str(e.get("type", "value_error"))})
    return out


def document_problem_media_type(app: FastAPI) -> None:
    """Make ``/openapi.json`` say what the error answers carry: every 4xx/5xx body documented as
    ``application/json`` (FastAPI's default for a ``responses`` model) is ``application/problem+json``."""
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        schema = generate()
        for operations in schema.get("paths", {}).values():
            for operation in operations.values():
                for status, response in operation.get("responses", {}).items():
                    content = response.get("content") or {}
                    if str(status)[:1] in "45" and "application/json" in content:
                        content[PROBLEM_MEDIA_TYPE] = content.pop("application/json")
        return schema

    app.openapi = openapi  # type: ignore[method-assign]


def install(app: FastAPI) -> None:
    """Register the exception handlers on ``app`` and document their media type in OpenAPI."""
    document_problem_media_type(app)

    @app.exception_handler(ex.PlanningError)
    async def _planning(_: Request, err: ex.PlanningError) -> Response:
        status, body = planning_error_body(err)
        metrics.planning_failure(err.code)
        return problem_response(status, body)

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> Response:
        errors = _validation_errors(exc)
        first = errors[0] if errors else {"loc": [], "msg": "invalid request"}
        where = ".".join(str(p) for p in first["loc"][1:] or first["loc"]) or "body"
        detail = f"{where}: {first['msg']}"
        if len(errors) > 1:
            detail += f" (and {len(errors) - 1} more)"
        body = problem_body(422, "validation", "Invalid request", detail, errors=errors)
        return problem_response(422, body)

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> Response:
        if exc.status_code == 400:
            # FastAPI's answer to a body it cannot decode (invalid UTF-8): a client error like
            # malformed JSON, so 422 `validation` naming the body (API.md has no 400).
            msg = "the body is not valid JSON text (UTF-8)"
            body = problem_body(
                422,
                "validation",
                "Invalid request",
                f"body: {msg}",
                errors=[{"loc": ["body"], "msg": msg}],
            )
            return problem_response(422, body)
        code = "too_large" if exc.status_code == 413 else "validation"
        title = {404: "Not found", 405: "Method not allowed", 413: "Request body too large"}.get(
            exc.status_code, "HTTP error"
        )
        body = problem_body(exc.status_code, code, title, str(exc.detail))
        response = problem_response(exc.status_code, body)
        # Keep the exception's headers: a 405 must list the supported methods in `Allow` (RFC 9110).
        response.headers.update(exc.headers or {})
        return response

    @app.exception_handler(Exception)
    async def _unexpected(_: Request, exc: Exception) -> Response:  # pragma: no cover - a bug
        log.exception("unhandled error", exc_info=exc)
        body = problem_body(500, "internal_error", "Internal error", "an unexpected error occurred")
        return problem_response(500, body)
