"""A scripted HTTP server on loopback for the client's retry tests: each request to it takes the
next ``Reply`` of its script (a status, headers and body; or a dropped connection; or a body cut
off mid-stream), and records what was asked."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass
class Reply:
    """status and JSON body (``body``) with ``headers``; ``drop``: close the connection without
    answering; ``cut``: send ``chunks`` of a chunked body, then close before its end; ``delay``
    [s] before answering."""

    status: int = 200
    body: Any = None
    headers: dict[str, str] = field(default_factory=dict)
    drop: bool = False
    chunks: list[bytes] | None = None
    cut: bool = False
    delay: float = 0.0


def problem(status: int, code: str, **extra: Any) -> dict[str, Any]:
    return {"type": f"https://trajectory-service/errors/{code}", "title": code, "status": status,
            "detail": f"a {code} answer", "code": code, **extra}  # fmt: skip


@dataclass
class Stub:
    url: str
    script: list[Reply]
    requests: list[tuple[str, str, Any]] = field(default_factory=list)
    """(method, path with query, decoded JSON body or None) of every request received."""


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    stub: Stub

    def log_message(self, *args: Any) -> None:  # quiet
        pass

    def _serve(self) -> None:
        length = int(self.headers.get("content-length") or 0)
        raw = self.rfile.read(length) if length else b""
        self.stub.requests.append((self.command, self.path, json.loads(raw) if raw else None))
        reply = (
            self.stub.script.pop(0)
            if self.stub.script
            else Reply(500, problem(500, "internal_error"))
        )
        time.sleep(reply.delay)
        if reply.drop:
            self.close_connection = True
            self.connection.close()
            return
        if reply.chunks is not None:
            self.send_response(reply.status)
            self.send_header("content-type", "application/x-ndjson")
            self.send_header("transfer-encoding", "chunked")
            self.end_headers()
            for chunk in reply.chunks:
                self.wfile.write(f"{len(chunk):x}\r\n".encode() + chunk + b"\r\n")
                self.wfile.flush()
            if reply.cut:
                self.close_connection = True
                self.connection.close()
                return
            self.wfile.write(b"0\r\n\r\n")
            return
        payload = json.dumps(reply.body).encode()
        self.send_response(reply.status)
        media = "application/json" if reply.status < 400 else "application/problem+json"
        self.send_header("content-type", media)
        self.send_header("content-length", str(len(payload)))
        for k, v in reply.headers.items():
            self.send_header(k, v)
        self.end_headers()
        self.wfile.write(payload)

    do_GET = do_POST = _serve


@contextmanager
def stub_server(script: list[Reply]) -> Iterator[Stub]:
    """A stub answering ``script`` in order on 127.0.0.1 at a free port, stopped on exit."""
    handler = type("Handler", (_Handler,), {})
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    stub = Stub(f"http://127.0.0.1:{server.server_address[1]}", list(script))
    handler.stub = stub
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield stub
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=5)
