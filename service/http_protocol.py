"""uvicorn's HTTP protocol with ``TCP_NODELAY`` on every connection, whatever the worker count.

With ``--workers`` above 1, uvicorn binds the listening socket itself (``Config.bind_socket``) with
``proto`` left at 0; accepted connections inherit it, and asyncio turns Nagle's algorithm off only
for sockets that report ``IPPROTO_TCP`` (uvicorn issue #3149). A response written as headers then
body then waits for the client's delayed ACK: measured here, every keep-alive request to two workers
took 44 ms instead of 0.8 ms. ``NoDelayHTTPProtocol`` is uvicorn's own protocol (``auto``: httptools
when installed, else h11) that sets the option when a connection is made; ``python -m service``
passes it to uvicorn as ``http=PROTOCOL``, an import string each worker process resolves.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket

from uvicorn.protocols.http.auto import AutoHTTPProtocol

PROTOCOL = "service.http_protocol:NoDelayHTTPProtocol"


def enable_nodelay(transport: asyncio.BaseTransport) -> bool:
    """Turn Nagle's algorithm off on the transport's TCP socket; False when it is not one."""
    sock = transport.get_extra_info("socket")
    if sock is None or sock.family not in (socket.AF_INET, socket.AF_INET6):
        return False
    with contextlib.suppress(OSError):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return True
    return False


class NoDelayHTTPProtocol(AutoHTTPProtocol):  # type: ignore[misc, valid-type]
    """``AutoHTTPProtocol`` with ``TCP_NODELAY`` set on each new connection."""

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        enable_nodelay(transport)
        super().connection_made(transport)
