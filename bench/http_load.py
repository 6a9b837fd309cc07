"""P6: the service under load on loopback: requests per second and p50/p99 latency of small joint
plans with 8 concurrent clients, against one worker and two; and the latency of one 1000-sample
quintic plan with its server-side split (planning, JSON encoding).

The load comes from 8 client threads, each with one keep-alive connection sending a pre-encoded
request and reading the answer by its Content-Length (a few microseconds of client work per request,
so the numbers are the server's, not an HTTP client library's). Every run is bounded by a request
count and a wall time, and only ever talks to 127.0.0.1. The client shares the 2 cores with the
server: with two workers the load generator takes CPU the workers would otherwise have.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from urllib.parse import urlsplit

import numpy as np
import orjson

from bench.harness import Row, Table, cpu_seconds, http_row, server

CLIENTS = 8
SMALL_PLAN = {
    "profile": "quintic",
    "start": {"positions": [0.0, -1.5, 1.5, 0.0, 0.5, 0.0]},
    "goal": {"positions": [1.0, -1.0, 0.7, 1.2, -0.5, 0.3]},
    "duration": 2.0,
    "samples": 50,
}
BIG_PLAN = dict(SMALL_PLAN, samples=1000)
_WAYPOINTS = np.cumsum(np.random.default_rng(6).uniform(-0.1, 0.1, (50, 6)), axis=0)
SPLINE_10K = {
    "waypoints": _WAYPOINTS.round(6).tolist(),
    "times": np.linspace(0.0, 10.0, 50).tolist(),
    "boundary": "natural",
    "samples": 10_000,
}
"""The issue's 10,000-point spline (about 4.3 MB in the default layout)."""
COLUMNS = "?layout=columns"


def _request(url: str, path: str, body: dict) -> tuple[str, int, bytes]:
    parts = urlsplit(url)
    payload = orjson.dumps(body)
    head = (
        f"POST {path} HTTP/1.1\r\nHost: {parts.hostname}:{parts.port}\r\n"
        f"Content-Type: application/json\r\nContent-Length: {len(payload)}\r\n\r\n"
    ).encode()
    return str(parts.hostname), int(parts.port or 80), head + payload


def _read_response(
    sock: socket.socket, buf: bytearray, decode: bool = False
) -> tuple[int, bytearray]:
    """Status and the rest of ``buf`` after one full response (Content-Length or chunked framing:
    trajectories over 5,000 points are streamed); ``decode``: parse a Content-Length body with
    orjson (as a client that reads the answer must)."""
    while b"\r\n\r\n" not in buf:
        _fill(sock, buf)
    end = buf.index(b"\r\n\r\n") + 4
    lines = bytes(buf[:end]).split(b"\r\n")
    status = int(lines[0].split()[1])
    headers = dict(
        (k.strip().lower(), v.strip()) for k, _, v in (line.partition(b":") for line in lines[1:])
    )
    del buf[:end]
    if headers.get(b"transfer-encoding", b"").lower() == b"chunked":
        while True:
            while b"\r\n" not in buf:
                _fill(sock, buf)
            line_end = buf.index(b"\r\n")
            size = int(bytes(buf[:line_end]).split(b";")[0], 16)
            while len(buf) < line_end + 2 + size + 2:
                _fill(sock, buf)
            del buf[: line_end + 2 + size + 2]
            if size == 0:
                return status, buf
    length = int(headers[b"content-length"])
    while len(buf) < length:
        _fill(sock, buf)
    if decode:
        orjson.loads(memoryview(buf)[:length])
    return status, buf[length:]


def _fill(sock: socket.socket, buf: bytearray) -> None:
    chunk = sock.recv(1 << 20)
    if not chunk:
        raise ConnectionError("the server closed the connection")
    buf += chunk


@contextlib.contextmanager
def raw_client(url: str) -> Iterator[Callable[[str, dict], int]]:
    """One keep-alive connection: ``post(path, body)`` sends and reads one whole answer."""
    parts = urlsplit(url)
    cache: dict[tuple[str, str], bytes] = {}
    with socket.create_connection((str(parts.hostname), int(parts.port or 80)), timeout=30) as sock:
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        buf = bytearray()

        def post(path: str, body: dict, decode: bool = False) -> int:
            nonlocal buf
            key = (path, repr(body))
            if key not in cache:
                cache[key] = _request(url, path, body)[2]
            sock.sendall(cache[key])
            status, buf = _read_response(sock, buf, decode)
            if status != 200:
                raise RuntimeError(f"HTTP {status}")
            return status

        yield post


@dataclass
class LoadResult:
    label: str
    latencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    elapsed: float = 0.0
    errors: int = 0
    server_cpu: float = float("nan")
    """CPU time [s] the server's processes spent during the run."""

    @property
    def rps(self) -> float:
        return len(self.latencies) / self.elapsed if self.elapsed > 0 else float("nan")


def load(url: str, path: str, body: dict, requests: int, seconds: float, label: str) -> LoadResult:
    """``requests`` POSTs of ``body`` from ``CLIENTS`` threads, stopping early after ``seconds``."""
    host, port, raw = _request(url, path, body)
    per_client = max(1, requests // CLIENTS)
    results: list[list[float]] = [[] for _ in range(CLIENTS)]
    errors = [0] * CLIENTS
    start_gate = threading.Barrier(CLIENTS + 1)
    stop_at = [0.0]

    def client(i: int) -> None:
        with socket.create_connection((host, port), timeout=30) as sock:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            buf = bytearray()
            start_gate.wait()
            for _ in range(per_client):
                if time.perf_counter() > stop_at[0]:
                    break
                t0 = time.perf_counter()
                sock.sendall(raw)
                status, buf = _read_response(sock, buf)
                results[i].append(time.perf_counter() - t0)
                errors[i] += status != 200

    threads = [threading.Thread(target=client, args=(i,), daemon=True) for i in range(CLIENTS)]
    for t in threads:
        t.start()
    started = time.perf_counter()
    stop_at[0] = started + seconds
    start_gate.wait()
    for t in threads:
        t.join(timeout=seconds + 60)
    elapsed = time.perf_counter() - started
    return LoadResult(label, np.concatenate([np.asarray(r) for r in results]), elapsed, sum(errors))


@dataclass
class LoadTable:
    key: str
    title: str
    results: list[LoadResult]
    latency: Table
    notes: list[str]

    @property
    def errors(self) -> list[str]:
        out = [
            f"{self.key} {r.label}: {r.errors} non-200 answers" for r in self.results if r.errors
        ]
        return out + self.latency.errors

    def markdown(self) -> list[str]:
        lines = [
            f"### {self.key}: {self.title}",
            "",
            "| P6 | requests/s | p50 [ms] | p99 [ms] | server CPU per request [ms] | "
            "requests/s per server core | requests | wall [s] | errors |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in self.results:
            p50, p99 = (np.percentile(r.latencies, q) * 1e3 for q in (50, 99))
            per = r.server_cpu / max(len(r.latencies), 1)
            lines.append(
                f"| {r.label} | {r.rps:.0f} | {p50:.2f} | {p99:.2f} | {per * 1e3:.2f} | "
                f"{1.0 / per if per > 0 else float('nan'):.0f} | {len(r.latencies)} | "
                f"{r.elapsed:.1f} | {r.errors} |"
            )
        lines.append("")
        lines += self.latency.markdown()[2:]
        lines += [f"- {n}" for n in self.notes] + [""]
        return lines


def _orjson_round_trip(client, url: str, body: dict) -> Callable[[], object]:
    """Encode and decode, with orjson in this process, the document the service answers."""
    document = orjson.loads(client.post(f"{url}/v1/trajectories/joint", json=body).content)
    return lambda: orjson.loads(orjson.dumps(document))


def encoding_split(reps: int = 200) -> tuple[float, float]:
    """Median [s] of planning and of encoding (``convert.trajectory_response``) one 1000-sample
    quintic in-process, as the route does them."""
    from core.joint.point_to_point import PointToPoint, plan_joint
    from service.convert import joint as convert

    plan_t, enc_t = [], []
    for _ in range(reps):
        t0 = time.perf_counter()
        plan = plan_joint(
            "quintic",
            PointToPoint.create(BIG_PLAN["start"]["positions"], BIG_PLAN["goal"]["positions"]),
            duration=BIG_PLAN["duration"],
            samples=BIG_PLAN["samples"],
        )
        t1 = time.perf_counter()
        convert.trajectory_response(plan.trajectory, "quintic", plan.warnings, t0, "float")
        t2 = time.perf_counter()
        plan_t.append(t1 - t0)
        enc_t.append(t2 - t1)
    return float(np.median(plan_t)), float(np.median(enc_t))


def p6_http(requests: int, seconds: float, latency_budget, measure) -> LoadTable:
    import httpx

    results = []
    latency_rows: list[Row] = []
    for workers in (1, 2):
        with server(workers) as live:
            url = live.url
            load(url, "/v1/trajectories/joint", SMALL_PLAN, 8 * CLIENTS, 10.0, "warm-up")
            cpu = cpu_seconds(live.pid)
            result = load(
                url, "/v1/trajectories/joint", SMALL_PLAN, requests, seconds,
                f"{workers} worker{'s' if workers > 1 else ''}, {CLIENTS} clients, "
                f"quintic 6 joints x {SMALL_PLAN['samples']} points",
            )  # fmt: skip
            result.server_cpu = cpu_seconds(live.pid) - cpu
            results.append(result)
            if workers == 1:
                with httpx.Client(timeout=30) as client, raw_client(url) as raw:
                    rows = [
                        Row(
                            "1 worker, 1 client: quintic 6 joints x 1000 points, raw socket",
                            lambda: raw("/v1/trajectories/joint", BIG_PLAN),
                            note="request sent, whole response received (the server's round trip)",
                        ),
                        http_row(
                            client, url, "/v1/trajectories/joint", BIG_PLAN,
                            "1 worker, 1 client: the same through httpx",
                        ),
                        Row(
                            "the same answer: orjson encode + decode in one process",
                            _orjson_round_trip(client, url, BIG_PLAN),
                            note="the serialization no round trip can avoid (P6 target: a round "
                            "trip <= 1.25x this)",
                        ),
                        Row(
                            "1 worker, 1 client: the same plan, ?layout=columns, raw socket",
                            lambda: raw("/v1/trajectories/joint" + COLUMNS, BIG_PLAN),
                            note="time_from_start and positions/velocities/accelerations as arrays",
                        ),
                        Row(
                            "1 worker, 1 client: spline 6 joints x 10,000 points, raw socket",
                            lambda: raw("/v1/trajectories/spline", SPLINE_10K),
                            note="default layout (one body; streamed only above 16 MiB)",
                        ),
                        Row(
                            "1 worker, 1 client: the same spline, ?layout=columns, raw socket",
                            lambda: raw("/v1/trajectories/spline" + COLUMNS, SPLINE_10K),
                            note="P6 target: <= 0.25x the default-layout row above",
                        ),
                        Row(
                            "1 worker, 1 client: the quintic, raw socket + orjson decode",
                            lambda: raw("/v1/trajectories/joint", BIG_PLAN, decode=True),
                            note="the round trip without an HTTP client library's own cost",
                        ),
                    ]  # fmt: skip
                    measure(Table("P6", "", rows[0].name, rows, unit="ms"), latency_budget)
                    latency_rows += rows
    plan_s, enc_s = encoding_split()
    body_bytes = len(orjson.dumps(BIG_PLAN))
    latency = Table("P6", "", latency_rows[0].name, latency_rows, unit="ms")
    medians = [r.median for r in latency_rows]
    layout_note = (
        f"Ratios in this run, against orjson encode+decode of the 1000-point quintic's answer "
        f"(P6 target <= 1.25x): the server's round trip (raw socket, whole answer received) "
        f"{medians[0] / medians[2]:.2f}x; the same with the client's orjson decoding "
        f"{medians[6] / medians[2]:.2f}x; through httpx {medians[1] / medians[2]:.2f}x (httpx "
        f"alone costs more client CPU than the orjson row). Columns / default, same plan "
        f"{medians[3] / medians[0]:.2f}x; 10,000-point spline columns / default "
        f"{medians[5] / medians[4]:.2f}x (target <= 0.25x)."
        if len(medians) == 7
        else ""
    )
    return LoadTable(
        "P6",
        "HTTP on loopback: small joint plans under 8 concurrent clients; one 1000-point plan",
        results,
        latency,
        notes=[
            f"Server side of the 1000-point plan, in-process medians: planning "
            f"{plan_s * 1e3:.2f} ms, JSON encoding of the response {enc_s * 1e3:.2f} ms "
            f"({enc_s / latency_rows[0].median:.0%} of the raw-socket round trip, "
            f"{enc_s / latency_rows[1].median:.0%} of the httpx one); request body "
            f"{body_bytes} bytes, response about 440 kB.",
            *([layout_note] if layout_note else []),
            "Load: 8 threads, one keep-alive connection each, bounded by a request count and a wall "
            "time. The load generator runs on the same 2 cores as the server and takes most of one "
            "of them, so two workers cannot show their throughput here; the server's CPU time per "
            "request (from /proc, all its processes) gives the capacity per core instead.",
        ],
    )
