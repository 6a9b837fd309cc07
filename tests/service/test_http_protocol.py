"""``python -m service`` gives uvicorn a protocol that sets TCP_NODELAY on every connection: with
several workers uvicorn's own listener leaves it off (uvicorn issue #3149), and each keep-alive
request then waited 44 ms for the client's delayed ACK."""

from __future__ import annotations

import socket

from uvicorn.importer import import_from_string
from uvicorn.protocols.http.h11_impl import H11Protocol

from service.middleware.http_protocol import PROTOCOL, ServiceHTTPProtocol, enable_nodelay


class FakeTransport:
    def __init__(self, sock: socket.socket | None) -> None:
        self.sock = sock

    def get_extra_info(self, name: str, default: object = None) -> object:
        return self.sock if name == "socket" else default


def test_enable_nodelay_on_a_connection_accepted_like_uvicorns_workers() -> None:
    # uvicorn's Config.bind_socket: family and type given, proto left at 0
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        with socket.create_connection(listener.getsockname()) as client:
            accepted, _ = listener.accept()
            with accepted:
                assert accepted.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) == 0
                assert enable_nodelay(FakeTransport(accepted))
                assert accepted.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) != 0
                client.sendall(b"x")


def test_enable_nodelay_leaves_other_transports_alone() -> None:
    assert not enable_nodelay(FakeTransport(None))
    left, right = socket.socketpair()  # AF_UNIX
    with left, right:
        assert not enable_nodelay(FakeTransport(left))


def test_the_import_string_given_to_uvicorn_names_the_protocol() -> None:
    cls = import_from_string(PROTOCOL)
    assert cls is ServiceHTTPProtocol
    assert issubclass(cls, H11Protocol)
