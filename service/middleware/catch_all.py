"""The outermost ASGI middleware: an unexpected exception answers a well-framed 500 problem+json.

Starlette's ``ServerErrorMiddleware`` sends its 500 and then re-raises, and uvicorn answers an
exception from the app by closing the transport: the client's keep-alive connection was reset
without ``Connection: close`` and its next request failed. Here the exception is logged (with the
request id) and answered, and the app returns normally, so the connection stays usable; a
``MemoryError`` is 503 ``overloaded`` with ``Retry-After``, never 500 (a retry may find memory). An
exception after the response has started cannot be answered; it is re-raised and uvicorn closes
the connection, which is the only honest end of a half-sent body.
"""

from __future__ import annotations

import logging

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.errors import internal_error_response, out_of_memory_response

log = logging.getLogger("service.errors")


class CatchAllMiddleware:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def send_tracking(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, receive, send_tracking)
        except MemoryError as exc:  # out of memory anywhere (a middleware too): 503, never 500
            if started:
                raise
            await out_of_memory_response(exc)(scope, receive, send)
        except Exception as exc:
            if started:
                raise
            log.exception("unhandled error", exc_info=exc)
            await internal_error_response()(scope, receive, send)
