"""One table: core/robots exceptions -> HTTP status + ``application/problem+json`` (RFC 9457) body.

Every error the service answers has ``type``, ``title``, ``status``, ``detail`` and ``code``; Cartesian
failures add ``s`` (path parameter in [0, 1]); validation failures add ``errors`` with each field's
location and a message. No body ever echoes the offending input value back.

Beside ``STATUS`` (planning errors), ``HTTP_CODES`` gives the codes of HTTP-level answers (404
``not_found``, 405 ``method_not_allowed``, 408 ``request_timeout``, 413 ``too_large``, 415
``unsupported_media_type``, 503 ``overloaded``); an ``ArithmeticError`` is 422 ``infeasible``; any other exception is 500
``internal_error``, answered by ``service.middleware.catch_all`` so the connection stays usable.
The HTTP protocol (``service.middleware.http_protocol``) answers what never reaches the app: 400
``bad_request`` (malformed HTTP), 408 (slow headers), 503 (too many connections).
"""

from __future__ import annotations

import logging
from typing import Any

import orjson
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import Response

from core import errors as ex
from service.field_paths import request_loc, without_tags
from service.middleware import metrics
from service.problem import PROBLEM_MEDIA_TYPE, problem_body

log = logging.getLogger("service.errors")


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
    ex.NoPathFound: 422,
}


def _finite_or_none(value: Any) -> Any:
    if isinstance(value, int):  # counts and indices (a program's ``segment``) stay integers
        return value
    try:
        f = float(value)
    except (TypeError, ValueError):
        return value
    return f if f == f and abs(f) != float("inf") else None


def problem_response(status: int, body: dict[str, Any]) -> Response:
    return Response(
        orjson.dumps(body, option=orjson.OPT_SERIALIZE_NUMPY),
        status_code=status,
        media_type=PROBLEM_MEDIA_TYPE,
    )


def planning_error_body(
    err: ex.PlanningError, model: type[BaseModel] | None = None
) -> tuple[int, dict[str, Any]]:
    """Status and problem body of a core/robots error (also used inside /v1/compare rows).

    ``errors`` names ``err.field`` as a path of the request ``model`` (``request_loc``: within the
    failing program segment, cut where the model ends); a ``validation`` error always has it (the
    body as a whole when no field is known)."""
    status = next((code for cls, code in STATUS.items() if isinstance(err, cls)), 422)
    extra: dict[str, Any] = {
        "s": None if err.s is None else _finite_or_none(round(float(err.s), 6)),
        "joint": err.joint,
        "sample": err.sample,
    }
    if err.field is not None or err.code == "validation":
        segment = err.extra.get("segment")
        loc = request_loc(model, err.field or (), segment if isinstance(segment, int) else None)
        extra["errors"] = [{"loc": ["body", *loc], "msg": err.detail}]
    extra.update({k: _finite_or_none(v) for k, v in err.extra.items()})
    return status, problem_body(status, err.code, err.title, err.detail, **extra)


def body_model(request: Request) -> type[BaseModel] | None:
    """The pydantic model of the matched route's JSON body, or None."""
    field = getattr(request.scope.get("route"), "body_field", None)
    model = getattr(getattr(field, "field_info", None), "annotation", None)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _message(error: Any) -> str:
    """pydantic's message of ``error``, without the input it would echo: an invalid union tag is
    named by its field and the expected tags (pydantic's own message quotes the client's tag)."""
    ctx = error.get("ctx") or {}
    if error.get("type") == "union_tag_invalid" and "expected_tags" in ctx:
        field = ctx.get("discriminator", "the tag")
        return f"{field} does not match any of the expected tags: {ctx['expected_tags']}"
    return str(error.get("msg", "invalid value"))


def _validation_errors(
    exc: RequestValidationError, model: type[BaseModel] | None
) -> list[dict[str, Any]]:
    """pydantic's errors with ``loc`` as the request spells it: without the union tags pydantic
    inserts (``robot.InlineRobot.urdf`` is ``robot.urdf``, ``segments.0.ptp.goal`` is
    ``segments.0.goal``), an invalid object key named by its object; each once."""
    out: list[dict[str, Any]] = []
    for e in exc.errors():
        loc = [p if isinstance(p, int | str) else str(p) for p in e.get("loc", ())]
        if loc[-1:] == ["[key]"]:  # a bad key of an object: name the object, never echo the key
            loc = loc[:-2]
        if loc[:1] == ["body"] and model is not None:
            loc = ["body", *without_tags(model, loc[1:])]
        row = {"loc": loc, "msg": _message(e)}
        row["type"] = str(e.get("type", "value_error"))
        if row not in out:
            out.append(row)
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
    async def _planning(request: Request, err: ex.PlanningError) -> Response:
        status, body = planning_error_body(err, body_model(request))
        metrics.planning_failure(err.code)
        return problem_response(status, body)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> Response:
        errors = _validation_errors(exc, body_model(request))
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
        fallback = "bad_request" if exc.status_code < 500 else "internal_error"
        code, title, detail = HTTP_CODES.get(
            exc.status_code, (fallback, "HTTP error", str(exc.detail))
        )
        if exc.status_code == 404 and exc.detail not in (None, "Not Found"):
            detail = str(exc.detail)  # a route's own 404 (the playground's static files)
        body = problem_body(exc.status_code, code, title, detail)
        response = problem_response(exc.status_code, body)
        # Keep the exception's headers: a 405 must list the supported methods in `Allow` (RFC 9110).
        response.headers.update(exc.headers or {})
        return response

    @app.exception_handler(ArithmeticError)
    async def _arithmetic(_: Request, exc: ArithmeticError) -> Response:
        # Numbers a request may hold can still overflow a formula (a ratio of extreme limits):
        # the request cannot be planned in double precision, a 422 rather than a 500.
        log.warning("arithmetic error answered as 422 infeasible: %r", exc)
        metrics.planning_failure(ex.Infeasible.code)
        body = problem_body(
            422,
            ex.Infeasible.code,
            ex.Infeasible.title,
            "the request's numbers overflow double-precision arithmetic; use less extreme values",
        )
        return problem_response(422, body)

    @app.exception_handler(Overloaded)
    async def _overloaded(_: Request, exc: Overloaded) -> Response:
        return overloaded_response(str(exc), exc.retry_after_s)

    @app.exception_handler(MemoryError)
    async def _out_of_memory(_: Request, exc: MemoryError) -> Response:
        return out_of_memory_response(exc)


class Overloaded(Exception):
    """The worker cannot take this request now (its response memory budget is spent): 503.

    Args:
        detail: What is exhausted, for the problem body.
        retry_after_s: Seconds the client should wait before retrying (``Retry-After``).
    """

    def __init__(self, detail: str, retry_after_s: int = 1) -> None:
        super().__init__(detail)
        self.retry_after_s = retry_after_s


HTTP_CODES: dict[int, tuple[str, str, str]] = {
    404: ("not_found", "Not found", "no endpoint serves this path"),
    405: ("method_not_allowed", "Method not allowed", "the endpoint does not accept this method"),
    408: ("request_timeout", "Request timeout", "the request was not received in time"),
    413: ("too_large", "Request body too large", "the request body is too large"),
    415: (
        "unsupported_media_type",
        "Unsupported media type",
        "the request body must be JSON: Content-Type application/json (or application/*+json)",
    ),
    503: ("overloaded", "Service overloaded", "the service is at capacity; retry later"),
}
"""HTTP-level errors (no planning involved): status -> (code, title, default detail)."""


def overloaded_response(detail: str, retry_after_s: int = 1) -> Response:
    """503 ``overloaded`` with ``Retry-After`` in [s]."""
    body = problem_body(
        503, "overloaded", "Service overloaded", detail, retry_after_s=retry_after_s
    )
    response = problem_response(503, body)
    response.headers["Retry-After"] = str(retry_after_s)
    return response


def out_of_memory_response(exc: MemoryError) -> Response:
    """503 ``overloaded`` for a ``MemoryError``: the worker could not allocate what the request
    needed now (others hold memory, or an address-space limit), which a retry may get; never 500."""
    log.warning("MemoryError answered as 503 overloaded: %r", exc)
    return overloaded_response("the worker is out of memory for this request; retry later")


def internal_error_response() -> Response:
    """500 ``internal_error``: the answer to a bug; the connection stays usable (it is a whole,
    well-framed response)."""
    body = problem_body(500, "internal_error", "Internal error", "an unexpected error occurred")
    return problem_response(500, body)
