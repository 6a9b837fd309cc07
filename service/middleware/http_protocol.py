"""uvicorn's h11 HTTP protocol, hardened: TCP_NODELAY, a header timeout, problem+json framing errors.

``python -m service`` passes ``ServiceHTTPProtocol`` to uvicorn as ``http=PROTOCOL``, an import
string each worker process resolves. On top of uvicorn's ``H11Protocol`` it

- sets ``TCP_NODELAY`` on each connection. With ``--workers`` above 1, uvicorn binds the listening
  socket itself (``Config.bind_socket``) with ``proto`` left at 0; accepted connections inherit it,
  and asyncio turns Nagle's algorithm off only for sockets that report ``IPPROTO_TCP`` (uvicorn
  issue #3149). A response written as headers then body then waited for the client's delayed ACK:
  every keep-alive request to two workers took 44 ms instead of 0.8 ms;
- gives a client ``TRAJ_HEADER_TIMEOUT_S`` from the first byte of a request (or from the moment
  it connects) to the end of its headers. uvicorn's keep-alive timer stops at the first byte and
  is not armed before it, so a client sending its headers one byte at a time, or nothing at all,
  held a connection for ever; now it gets 408 ``request_timeout`` (silence: just the close);
- answers a request h11 cannot parse (``Content-Length: -1``, a bad request line, headers larger
  than ``h11_max_incomplete_event_size``) with 400 problem+json ``bad_request`` instead of uvicorn's
  plain text, and the 503 of uvicorn's ``limit_concurrency`` with problem+json ``overloaded``.

The h11 implementation is used whether or not httptools is installed, so the behaviour above does
not depend on the image. This module imports neither the app nor prometheus_client (the supervisor
process imports it before the workers' environment is ready).
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from typing import Any

from starlette.types import Receive, Scope, Send
from uvicorn.protocols.http import h11_impl
from uvicorn.protocols.http.h11_impl import H11Protocol

from service.problem import PROBLEM_MEDIA_TYPE, problem_bytes
from service.settings import Settings

PROTOCOL = "service.middleware.http_protocol:ServiceHTTPProtocol"
RETRY_AFTER_S = 1
"""``Retry-After`` [s] of a 503 for too many connections."""


def enable_nodelay(transport: asyncio.BaseTransport) -> bool:
    """Turn Nagle's algorithm off on the transport's TCP socket; False when it is not one."""
    sock = transport.get_extra_info("socket")
    if sock is None or sock.family not in (socket.AF_INET, socket.AF_INET6):
        return False
    with contextlib.suppress(OSError):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return True
    return False


def raw_problem(status: int, reason: str, code: str, detail: str, **headers: str) -> bytes:
    """A complete HTTP/1.1 problem+json response with ``Connection: close``, as bytes."""
    body = problem_bytes(status, code, reason, detail)
    lines = [
        f"HTTP/1.1 {status} {reason}",
        f"content-type: {PROBLEM_MEDIA_TYPE}",
        f"content-length: {len(body)}",
        "connection: close",
        *(f"{k.replace('_', '-')}: {v}" for k, v in headers.items()),
    ]
    return ("\r\n".join(lines) + "\r\n\r\n").encode("ascii") + body


async def service_unavailable(scope: Scope, receive: Receive, send: Send) -> None:
    """uvicorn's answer over ``limit_concurrency``, as 503 problem+json ``overloaded``."""
    body = problem_bytes(
        503,
        "overloaded",
        "Service overloaded",
        "the worker has reached its limit of concurrent connections; retry later",
        retry_after_s=RETRY_AFTER_S,
    )
    headers = [
        (b"content-type", PROBLEM_MEDIA_TYPE.encode()),
        (b"content-length", str(len(body)).encode()),
        (b"retry-after", str(RETRY_AFTER_S).encode()),
        (b"connection", b"close"),
    ]
    await send({"type": "http.response.start", "status": 503, "headers": headers})
    await send({"type": "http.response.body", "body": body, "more_body": False})


# uvicorn looks the over-limit app up by this module-level name on each request; ours answers the
# same 503, in problem+json like every other error of the service.
h11_impl.service_unavailable = service_unavailable  # type: ignore[assignment]  # an ASGI app


class ServiceHTTPProtocol(H11Protocol):  # type: ignore[misc]
    """``H11Protocol`` with TCP_NODELAY, a request-header timeout and problem+json 400s."""

    header_timeout_s: float | None = None
    """[s]; read from ``TRAJ_HEADER_TIMEOUT_S`` by the first connection of a worker."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if ServiceHTTPProtocol.header_timeout_s is None:
            ServiceHTTPProtocol.header_timeout_s = Settings.from_env().header_timeout_s
        self._head_timer: asyncio.TimerHandle | None = None
        self._head_cycle: object = None
        self._head_started = False

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        enable_nodelay(transport)
        super().connection_made(transport)
        # uvicorn arms no timer before the first byte: a connection that never sends anything
        # would stay open for ever (3,000 of them, bounded only by the fd limit).
        self._arm_head_timer()

    def connection_lost(self, exc: Exception | None) -> None:
        self._cancel_head_timer()
        super().connection_lost(exc)

    def data_received(self, data: bytes) -> None:
        if self._head_timer is None and (self.cycle is None or self.cycle.response_complete):
            # First bytes of a new request: its headers must be complete within the timeout.
            self._arm_head_timer()
        self._head_started = True
        super().data_received(data)
        if self._head_timer is not None and self.cycle is not self._head_cycle:
            self._cancel_head_timer()  # h11 parsed the request line and headers

    def _arm_head_timer(self) -> None:
        self._head_cycle = self.cycle
        self._head_started = False
        self._head_timer = self.loop.call_later(self.header_timeout_s or 10.0, self._head_timeout)

    def _cancel_head_timer(self) -> None:
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None

    def _head_timeout(self) -> None:
        self._head_timer = None
        if self.transport.is_closing():
            return
        if not self._head_started:  # a new connection that never sent a byte: just close it
            self.transport.close()
            return
        self.logger.info("request headers not received within %g s", self.header_timeout_s)
        self.transport.write(
            raw_problem(
                408,
                "Request Timeout",
                "request_timeout",
                f"the request line and headers did not arrive within {self.header_timeout_s:g} s",
            )
        )
        self.transport.close()

    def send_400_response(self, msg: str) -> None:
        self._cancel_head_timer()
        self.transport.write(
            raw_problem(
                400,
                "Bad Request",
                "bad_request",
                "the request is not valid HTTP/1.1 (request line, headers or framing)",
            )
        )
        self.transport.close()
