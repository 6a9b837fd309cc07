"""Pure ASGI middleware: request id, Prometheus request metrics and one access log line per request.

Outermost of the app's middlewares, so a 413 from the body limit is counted and carries its id too.
Per request it costs a header scan, two clock reads, two metric updates and (at ``info``) one log line.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Any

from starlette.routing import BaseRoute, compile_path
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.middleware import metrics
from service.middleware.logging_setup import REQUEST_ID, request_id_from

try:
    from fastapi.routing import iter_route_contexts
except ImportError:  # older FastAPI copies included routes into app.routes
    iter_route_contexts = None  # type: ignore[assignment]

access = logging.getLogger("service.access")

_HEADER = b"x-request-id"
_MAX_PATH_LOGGED = 256


class ObservabilityMiddleware:
    """Set ``REQUEST_ID`` (echoed as ``X-Request-ID``), then count, time and log the request.

    Args:
        app: The wrapped ASGI app.
        routes: The app's routes, to name the template of a request that never reached the router
            (rejected by an inner middleware); the router itself leaves its match in ``scope["route"]``.
        access_log: Emit an ``info`` line on ``service.access`` per request.
    """

    def __init__(self, app: ASGIApp, routes: Sequence[BaseRoute], access_log: bool = True) -> None:
        self.app = app
        self.routes = routes
        self.access_log = access_log

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        incoming = None
        for key, value in scope["headers"]:
            if key == _HEADER:
                incoming = value
                break
        request_id = request_id_from(incoming)
        token = REQUEST_ID.set(request_id)
        state = scope.get("state")
        if isinstance(state, dict):
            state["request_id"] = request_id
        echo = (_HEADER, request_id.encode("ascii"))
        status = 0
        start = time.perf_counter()

        async def send_with_id(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
                message = {**message, "headers": [*message.get("headers", ()), echo]}
            await send(message)

        metrics.IN_PROGRESS.inc()
        try:
            await self.app(scope, receive, send_with_id)
        except Exception:
            # The error handler outside this middleware answers 500 (if nothing was sent yet) and
            # logs the exception; the context keeps the request id for that line.
            self._finish(scope, status or 500, start)
            raise
        finally:
            metrics.IN_PROGRESS.dec()
        self._finish(scope, status, start)
        REQUEST_ID.reset(token)

    def _finish(self, scope: Scope, status: int, start: float) -> None:
        seconds = time.perf_counter() - start
        route = self._route(scope)
        method = scope["method"]
        metrics.observe_request(route, method, status, seconds)
        if self.access_log and access.isEnabledFor(logging.INFO):
            path = scope["path"][:_MAX_PATH_LOGGED]
            access.info(
                "%s %s %d",
                method,
                path,
                status,
                extra={
                    "method": method,
                    "route": route,
                    "path": path,
                    "status": status,
                    "duration_ms": round(seconds * 1000.0, 3),
                },
            )

    def _route(self, scope: Scope) -> str:
        """The template of the route that served ``scope``, or ``UNMATCHED``."""
        path = scope["path"]
        root = scope.get("root_path", "")
        if root and path.startswith(root):
            path = path[len(root) :] or "/"
        route: Any = scope.get("route")
        regex = getattr(route, "path_regex", None)
        if regex is not None and regex.match(path):
            return str(route.path_format)
        # Not routed (rejected by an inner middleware, or 404), or routed through an include prefix
        # the route object does not know: match the app's templates (a short scan, off the hot path).
        for template in _templates(self.routes):
            if compile_path(template)[0].match(path):
                return template
        return metrics.UNMATCHED


def _templates(routes: Sequence[BaseRoute]) -> list[str]:
    """Every route template of the app, nested routers flattened (FastAPI >= 0.13x includes lazily)."""
    items: Any = routes if iter_route_contexts is None else iter_route_contexts(routes)
    return [template for r in items if (template := getattr(r, "path_format", None))]
