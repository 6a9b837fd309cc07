"""ASGI middleware that bounds request bodies in size and in time, with or without Content-Length.

The body is read (at most ``max_bytes``) before the app sees it; one byte more answers 413
problem+json, so a chunked upload cannot slip past the limit. A client that leaves more than
``timeout_s`` between two pieces of its body, or whose whole body has not arrived ``deadline_s``
after the app got the request (its headers complete), gets 408 ``request_timeout`` and the
connection is closed: neither a stalled nor a trickled upload (one byte a second arrives within any
per-piece timeout) can hold a worker's connection slot longer than ``deadline_s``.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.errors import problem_response
from service.problem import problem_body


class BodyLimitMiddleware:
    """Args: app; max_bytes: largest body in [bytes]; timeout_s: longest wait for the next piece of
    the body in [s]; deadline_s: longest time for the whole body in [s] (``None``: no limit)."""

    def __init__(
        self,
        app: ASGIApp,
        max_bytes: int,
        timeout_s: float | None = None,
        deadline_s: float | None = None,
    ) -> None:
        self.app = app
        self.max_bytes = max_bytes
        self.timeout_s = timeout_s
        self.deadline_s = deadline_s

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] in ("GET", "HEAD", "OPTIONS"):
            await self.app(scope, receive, send)
            return
        declared = _content_length(scope)
        if declared is not None and declared > self.max_bytes:
            await self._reject(scope, receive, send)
            return
        chunks: list[bytes] = []
        size = 0
        loop = asyncio.get_running_loop()
        end = math.inf if self.deadline_s is None else loop.time() + self.deadline_s
        while True:
            piece_end = math.inf if self.timeout_s is None else loop.time() + self.timeout_s
            when = min(piece_end, end)
            try:
                # A timer handle, not the task asyncio.wait_for creates for every piece.
                async with asyncio.timeout_at(None if when == math.inf else when):
                    message = await receive()
            except TimeoutError:
                await self._timeout(scope, receive, send, whole=end <= piece_end)
                return
            if message["type"] == "http.disconnect":
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_bytes:
                await self._reject(scope, receive, send)
                return
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        replayed = False

        async def replay() -> Message:
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)

    async def _reject(self, scope: Scope, receive: Receive, send: Send) -> None:
        detail = f"request body exceeds the limit of {self.max_bytes} bytes"
        body = problem_body(413, "too_large", "Request body too large", detail)
        response = problem_response(413, body)
        response.headers["Connection"] = "close"
        await response(scope, receive, send)

    async def _timeout(self, scope: Scope, receive: Receive, send: Send, whole: bool) -> None:
        if whole:
            detail = f"the request body did not arrive in full within {self.deadline_s:g} s"
        else:
            detail = f"no part of the request body arrived within {self.timeout_s:g} s"
        body = problem_body(408, "request_timeout", "Request timeout", detail)
        response = problem_response(408, body)
        response.headers["Connection"] = "close"
        await response(scope, receive, send)


def _content_length(scope: Scope) -> int | None:
    headers: Any = scope.get("headers", [])
    for key, value in headers:
        if key == b"content-length":
            try:
                return int(value)
            except ValueError:
                return None
    return None
