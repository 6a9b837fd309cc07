"""One batch item answered by its endpoint, in process: a POST through the app's own router.

The item's body goes to the route as the request body of an ASGI request built from the batch's
(same app, client and server, a fresh ``state``, ``Content-Type: application/json``) and the
answer's status and bytes are captured. Routing, the route's schema, its dependencies (a deadline,
the response policy, the ``?layout=`` and ``?time_format=`` the batch passes on) and the app's
exception handlers all run as for a request of its own, so the answer is the endpoint's answer to
the same body, byte for byte. The middleware stack (request id, metrics, access log, body limit)
wraps the batch once and is not run again per item. An exception no handler answers is logged and
captured as 500 ``internal_error``, as ``service.middleware.catch_all`` answers it for a request.
"""

from __future__ import annotations

import asyncio
import logging
from contextlib import AsyncExitStack
from dataclasses import dataclass
from typing import Any

from starlette.types import Message, Scope

from service.problem import PROBLEM_MEDIA_TYPE, problem_bytes

log = logging.getLogger("service.batch")

INHERITED = (
    "type",
    "asgi",
    "http_version",
    "scheme",
    "server",
    "client",
    "root_path",
    "app",
    "starlette.exception_handlers",
)
"""Scope keys an item's request takes from its batch's (everything else is its own)."""


@dataclass(frozen=True)
class Answer:
    """An endpoint's answer: ``status``, ``body`` (JSON or problem+json bytes), ``media_type``."""

    status: int
    body: bytes
    media_type: str


def internal_error() -> Answer:
    """The answer to a defect met while answering an item (500 ``internal_error``)."""
    body = problem_bytes(500, "internal_error", "Internal error", "an unexpected error occurred")
    return Answer(500, body, PROBLEM_MEDIA_TYPE)


async def post(batch_scope: Scope, path: str, body: bytes, query: bytes = b"") -> Answer:
    """``POST path?query`` with the JSON ``body`` to the app serving ``batch_scope``, answered by
    its router in this task; the whole answer, also when the route streams it."""
    scope: dict[str, Any] = {k: batch_scope[k] for k in INHERITED if k in batch_scope}
    scope.update(
        method="POST",
        path=path,
        raw_path=path.encode("ascii"),
        query_string=query,
        headers=[
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode("ascii")),
        ],
        state={},
    )
    delivered = False
    status, media_type, chunks = 500, "", []

    async def receive() -> Message:
        nonlocal delivered
        if not delivered:
            delivered = True
            return {"type": "http.request", "body": body, "more_body": False}
        await asyncio.Event().wait()  # no disconnect of its own: cancelled with its batch
        raise AssertionError("unreachable")  # pragma: no cover

    async def send(message: Message) -> None:
        nonlocal status, media_type
        if message["type"] == "http.response.start":
            status = int(message["status"])
            headers = dict(message.get("headers", ()))
            media_type = headers.get(b"content-type", b"").decode("latin-1")
        elif message["type"] == "http.response.body":
            chunks.append(bytes(message.get("body", b"")))

    try:
        async with AsyncExitStack() as stack:
            scope["fastapi_middleware_astack"] = stack  # what FastAPI's own middleware provides
            await scope["app"].router(scope, receive, send)
    except Exception as exc:
        log.exception("unhandled error in a batch item (%s)", path, exc_info=exc)
        return internal_error()
    return Answer(status, b"".join(chunks), media_type)
