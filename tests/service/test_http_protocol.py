"""``python -m service`` gives uvicorn its own HTTP protocol (``service.middleware.http_protocol``).

It sets TCP_NODELAY on every connection (with several workers uvicorn's own listener leaves it off,
uvicorn issue #3149, and each keep-alive request waited 44 ms for the client's delayed ACK). Over a
real uvicorn server on loopback, one raw TCP connection at a time (issue 19): an unexpected error is
a 500 problem+json that leaves the keep-alive connection usable; malformed framing is 400
problem+json; slow headers or bodies get 408 and are cut off; a client that does not read is
disconnected; connections over the limit get 503 problem+json."""

from __future__ import annotations

import asyncio
import json
import select
import socket
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
import uvicorn
from uvicorn.importer import import_from_string
from uvicorn.protocols.http.h11_impl import H11Protocol

from service import encoding
from service.admission import MemoryBudget, Reservation
from service.app import create_app
from service.middleware.http_protocol import PROTOCOL, ServiceHTTPProtocol, enable_nodelay
from service.settings import Settings


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


# ---------------------------------------------- a real uvicorn server, one connection at a time


QUINTIC_6 = {
    "profile": "quintic",
    "start": {"positions": [0.0] * 6},
    "goal": {"positions": [1.0] * 6},
    "duration": 2.0,
    "samples": 100_000,
}


class Running:
    """A uvicorn server on loopback in a thread, with the service's HTTP protocol."""

    def __init__(self, settings: Settings, limit_concurrency: int | None = None) -> None:
        app = create_app(settings)

        @app.get("/boom")
        def boom() -> None:
            raise RuntimeError("a bug")

        config = uvicorn.Config(
            app,
            host="127.0.0.1",
            port=0,
            http=ServiceHTTPProtocol,
            log_level="critical",
            timeout_keep_alive=settings.keep_alive_timeout_s,
            limit_concurrency=limit_concurrency,
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        for _ in range(500):
            if self.server.started:
                break
            time.sleep(0.01)
        sock = self.server.servers[0].sockets[0]
        self.address = sock.getsockname()[:2]
        self.url = f"http://{self.address[0]}:{self.address[1]}"

    def connect(self) -> socket.socket:
        return socket.create_connection(self.address, timeout=10)

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(10)


@pytest.fixture
def running(monkeypatch: pytest.MonkeyPatch) -> Iterator[Running]:
    monkeypatch.setattr(ServiceHTTPProtocol, "header_timeout_s", 0.5)
    settings = Settings(access_log=False, body_timeout_s=0.5, write_timeout_s=0.5)
    server = Running(settings)
    yield server
    server.stop()


def read_response(sock: socket.socket) -> tuple[int, dict[str, str], bytes]:
    """One Content-Length framed HTTP/1.1 response from ``sock``."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(65536)
        assert chunk, f"connection closed before a response head: {data!r}"
        data += chunk
    head, _, rest = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    status = int(lines[0].split()[1])
    headers = {k.lower(): v.strip() for k, v in (line.split(":", 1) for line in lines[1:])}
    length = int(headers["content-length"])
    while len(rest) < length:
        chunk = sock.recv(65536)
        assert chunk, "connection closed inside a body"
        rest += chunk
    return status, headers, rest[:length]


def request_bytes(method: str, path: str, body: bytes = b"") -> bytes:
    head = f"{method} {path} HTTP/1.1\r\nHost: test\r\nContent-Length: {len(body)}\r\n"
    if body:
        head += "Content-Type: application/json\r\n"
    return head.encode() + b"\r\n" + body


def assert_problem(status: int, headers: dict[str, str], body: bytes, code: str) -> dict:
    assert headers["content-type"] == "application/problem+json", headers
    doc = json.loads(body)
    assert doc["status"] == status and doc["code"] == code, doc
    assert doc["type"].endswith("/" + code) and doc["title"] and doc["detail"]
    return doc


def closed(sock: socket.socket, within_s: float = 2.0) -> bool:
    """True when the server closes ``sock`` within ``within_s`` (EOF or reset)."""
    sock.settimeout(within_s)
    try:
        while sock.recv(65536):  # an answer (a 408) may come first
            pass
        return True
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False


def test_an_unexpected_error_is_a_500_problem_and_the_connection_stays_usable(
    running: Running,
) -> None:
    with running.connect() as sock:  # one TCP connection for all three requests
        for path, expected in (("/boom", 500), ("/health", 200), ("/boom", 500)):
            sock.sendall(request_bytes("GET", path))
            status, headers, body = read_response(sock)
            assert status == expected, body
            assert headers.get("connection", "keep-alive") != "close", headers
            if status == 500:
                doc = assert_problem(status, headers, body, "internal_error")
                assert "a bug" not in body.decode()  # no internals leak
                assert doc["detail"] == "an unexpected error occurred"
    with httpx.Client(base_url=running.url) as client:  # the reused client of the issue
        for _ in range(3):
            assert client.get("/boom").status_code == 500
            assert client.get("/health").status_code == 200


@pytest.mark.parametrize(
    "head",
    [
        b"POST /v1/trajectories/joint HTTP/1.1\r\nHost: t\r\nContent-Length: -1\r\n\r\n",
        b"POST /v1/trajectories/joint HTTP/1.1\r\nHost: t\r\nContent-Length: 1x\r\n\r\n",
        b"POST /v1/trajectories/joint HTTP/1.1\r\nHost: t\r\nContent-Length: 2\r\n"
        b"Content-Length: 3\r\n\r\n",
        b"GET /health HTTP/1.1\r\nHost: t\r\nBad Header\r\n\r\n",
        b"NOT-HTTP\r\n\r\n",
        # headers still incomplete past h11's 16 KiB limit
        b"GET /health HTTP/1.1\r\nHost: t\r\nX-Big: " + b"a" * 40_000,
    ],
)
def test_malformed_framing_is_a_400_problem_not_plain_text(running: Running, head: bytes) -> None:
    with running.connect() as sock:
        sock.sendall(head)
        status, headers, body = read_response(sock)
        assert status == 400, body
        assert headers["connection"] == "close"
        assert_problem(status, headers, body, "bad_request")
        assert closed(sock)


def test_a_client_that_sends_headers_slowly_is_cut_off(running: Running) -> None:
    with running.connect() as sock:
        started = time.perf_counter()
        sock.sendall(b"GET /health HTTP/1.1\r\n")
        answer = b""
        sock.settimeout(0.1)
        for _ in range(40):  # one header byte every 0.1 s: 4 s, far past the 0.5 s timeout
            try:
                sock.sendall(b"X")
                chunk = sock.recv(65536)
            except TimeoutError:
                continue
            except (BrokenPipeError, ConnectionResetError):
                break
            answer += chunk
            if not chunk:
                break
        elapsed = time.perf_counter() - started
    assert elapsed < 1.5, elapsed
    assert answer.startswith(b"HTTP/1.1 408 "), answer
    head, _, body = answer.partition(b"\r\n\r\n")
    assert b"connection: close" in head.lower() and b"application/problem+json" in head
    assert json.loads(body)["code"] == "request_timeout"


def test_headers_in_pieces_within_the_timeout_are_served(running: Running) -> None:
    with running.connect() as sock:
        for _ in range(2):  # and again on the same connection: the timer restarts per request
            for piece in (b"GET /health HTTP/1.1\r\n", b"Host: t\r\n", b"\r\n"):
                sock.sendall(piece)
                time.sleep(0.1)
            status, _, _ = read_response(sock)
            assert status == 200
        time.sleep(0.7)  # idle between requests is the keep-alive timeout's business (5 s)
        sock.sendall(request_bytes("GET", "/health"))
        assert read_response(sock)[0] == 200


def test_a_client_that_sends_its_body_slowly_gets_408(running: Running) -> None:
    with running.connect() as sock:
        body = json.dumps(QUINTIC_6).encode()
        sock.sendall(request_bytes("POST", "/v1/trajectories/joint", body)[:-20])
        started = time.perf_counter()
        status, headers, answer = read_response(sock)
        assert status == 408 and time.perf_counter() - started < 1.5
        assert headers["connection"] == "close"
        assert_problem(status, headers, answer, "request_timeout")
        assert closed(sock)


def test_a_body_trickled_byte_by_byte_is_cut_off_at_the_body_deadline() -> None:
    """Issue 26.4: one byte every 0.1 s never stalls for the 0.5 s piece timeout, but the whole
    body must arrive within ``TRAJ_BODY_DEADLINE_S`` (1 s here) of the headers: then 408
    problem+json and the connection is closed (it was held for as long as the client kept
    trickling)."""
    server = Running(
        Settings(access_log=False, body_timeout_s=0.5, body_deadline_s=1.0, write_timeout_s=0.5)
    )
    try:
        with server.connect() as sock:
            body = json.dumps(QUINTIC_6).encode()
            head = request_bytes("POST", "/v1/trajectories/joint", body)[: -len(body)]
            sock.sendall(head)
            started = time.perf_counter()
            for byte in body:  # 1.5 s of trickle, one byte each 0.1 s, if the server let it
                if select.select([sock], [], [], 0.1)[0]:
                    break  # the server answered
                sock.sendall(bytes([byte]))
            elapsed = time.perf_counter() - started
            status, headers, answer = read_response(sock)
            assert status == 408 and 0.9 < elapsed < 1.4, (status, elapsed)
            assert headers["connection"] == "close"
            doc = assert_problem(status, headers, answer, "request_timeout")
            assert "in full within 1 s" in doc["detail"]
            assert closed(sock)
    finally:
        server.stop()


def test_a_client_that_does_not_read_is_disconnected(running: Running) -> None:
    body = json.dumps(QUINTIC_6).encode()
    with httpx.Client(base_url=running.url) as client:  # the full answer, for its size
        full = client.post(
            "/v1/trajectories/joint", content=body, headers={"content-type": "application/json"}
        )
        assert full.status_code == 200
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    with sock:
        sock.connect(running.address)
        sock.sendall(request_bytes("POST", "/v1/trajectories/joint", body))
        time.sleep(2.0)  # read nothing: the server's sends block, the 0.5 s write timeout fires
        sock.settimeout(5)
        received = 0
        try:
            while chunk := sock.recv(1 << 20):
                received += len(chunk)
        except ConnectionResetError:
            pass
    assert len(full.content) > 10_000_000
    assert received < len(full.content), (received, len(full.content))


def test_more_connections_than_the_limit_get_a_503_problem() -> None:
    server = Running(Settings(access_log=False), limit_concurrency=3)
    try:
        idle = [server.connect() for _ in range(2)]
        time.sleep(0.2)
        with server.connect() as sock:
            sock.sendall(request_bytes("GET", "/health"))
            status, headers, body = read_response(sock)
        assert status == 503 and headers["retry-after"] == "1"
        assert_problem(status, headers, body, "overloaded")
        for s in idle:
            s.close()
        time.sleep(0.2)
        with httpx.Client(base_url=server.url) as client:
            assert client.get("/health").status_code == 200
    finally:
        server.stop()


def test_the_protocol_reads_its_header_timeout_from_the_environment(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(ServiceHTTPProtocol, "header_timeout_s", None)
    monkeypatch.setenv("TRAJ_HEADER_TIMEOUT_S", "2.5")
    config = uvicorn.Config(create_app(Settings(access_log=False)), http=ServiceHTTPProtocol)
    loop = asyncio.new_event_loop()
    try:
        ServiceHTTPProtocol(config, uvicorn.server.ServerState(), {}, _loop=loop)
    finally:
        loop.close()
    assert ServiceHTTPProtocol.header_timeout_s == 2.5


def test_a_connection_that_never_sends_a_byte_is_closed(running: Running) -> None:
    with running.connect() as sock:
        started = time.perf_counter()
        assert closed(sock, within_s=3.0)
        assert 0.3 < time.perf_counter() - started < 1.5


def test_many_slow_clients_are_all_cut_off_and_the_server_still_answers(running: Running) -> None:
    """The probe of issue 19 item 8 (3,000 slow connections stayed open), scaled to 200: half send
    one header byte, half nothing; all are closed after the 0.5 s header timeout."""
    socks = [running.connect() for _ in range(200)]
    try:
        for i, sock in enumerate(socks):
            if i % 2:
                sock.sendall(b"G")
        time.sleep(1.0)
        assert all(closed(sock, within_s=2.0) for sock in socks)
        with httpx.Client(base_url=running.url) as client:
            assert client.get("/health").status_code == 200
    finally:
        for sock in socks:
            sock.close()


def test_concurrent_large_answers_never_exceed_the_workers_budget(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The amplification probe of issue 19 item 4, scaled down: 8 clients at once ask for a
    100,000-point answer (about 30 MB estimated each) from a worker whose budget holds two. Every
    answer is a 200 or a 503 ``overloaded``, the bytes in flight never exceed the budget, and all
    of them are returned at the end."""
    budget = MemoryBudget()
    peak = 0
    reserve = budget.reserve

    def tracking(nbytes: int, limit: int | None) -> Reservation:
        nonlocal peak
        reservation = reserve(nbytes, limit)
        peak = max(peak, budget.in_flight)
        return reservation

    monkeypatch.setattr(budget, "reserve", tracking)
    monkeypatch.setattr(encoding, "RESPONSE_BUDGET", budget)
    one = encoding.estimate_bytes({"joint_names": ["j"] * 6, "time_from_start": [0.0] * 100_000})
    server = Running(Settings(access_log=False, response_budget_bytes=2 * one + 1))
    statuses: list[int] = []
    try:

        def client() -> None:
            with httpx.Client(base_url=server.url, timeout=60) as c:
                r = c.post("/v1/trajectories/joint", json=QUINTIC_6)
                statuses.append(r.status_code)
                if r.status_code == 503:
                    assert r.json()["code"] == "overloaded" and r.headers["retry-after"] == "1"
                else:
                    assert len(r.json()["points"]) == 100_000

        threads = [threading.Thread(target=client) for _ in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(120)
    finally:
        server.stop()
    assert len(statuses) == 8 and set(statuses) <= {200, 503}, statuses
    assert 200 in statuses
    assert 0 < peak <= 2 * one + 1, (peak, one)
    assert budget.in_flight == 0
