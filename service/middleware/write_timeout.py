"""ASGI middleware: a client that stops reading its response is cut off after ``timeout_s``.

uvicorn's ``send`` waits while the connection's write buffer is full (flow control), so a client
that never reads would hold the response, and the memory behind it, for ever. Each ``send`` here
gets ``timeout_s``; past it ``ClientTooSlow`` is raised, the response is abandoned and uvicorn
closes the connection (the body is half sent, so nothing else is honest).
"""

from __future__ import annotations

import asyncio

from starlette.types import ASGIApp, Message, Receive, Scope, Send


class ClientTooSlow(Exception):
    """The client did not accept a piece of the response within the write timeout."""


class WriteTimeoutMiddleware:
    """Args: app; timeout_s: longest wait for one ``send`` in [s]."""

    def __init__(self, app: ASGIApp, timeout_s: float) -> None:
        self.app = app
        self.timeout_s = timeout_s

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        timeout = self.timeout_s

        async def send_with_timeout(message: Message) -> None:
            try:
                async with asyncio.timeout(timeout):  # a timer handle, no task per send
                    await send(message)
            except TimeoutError:
                raise ClientTooSlow(
                    f"the client read nothing of the response for {timeout:g} s"
                ) from None

        await self.app(scope, receive, send_with_timeout)
