"""A bounded load test of the service on loopback: a mixed workload against ``--workers 2``.

``python -m bench.load`` starts ``python -m service --host 127.0.0.1 --port <free> --workers 2``,
waits for it, and sends a fixed, seeded sequence of requests (``--requests``, default 6000) from
``--concurrency`` client threads (default 4, each with its own keep-alive httpx client), stopping at
``--max-seconds`` (default 300) whatever happens. Only loopback addresses are ever contacted
(``--url`` must be 127.0.0.1, localhost or [::1]). It prints, and with ``--json`` writes:

- per endpoint: requests, errors (anything but the expected status), p50, p99 and max latency [ms];
- the resident memory (RSS, ``/proc/<pid>/status``) of each worker: idle after start, during the
  first and the last 1000 requests after the warm-up (``--warmup``, default 500), and the growth;
- the workers' peak RSS (``VmHWM``) after serving the largest allowed response (100,000 points,
  7 joints, about 51 MB of JSON), and after one of 64 joints (the schema's widest).

The workload (weights in ``MIX``): health and robot listings, FK and IK on the four shipped robots,
joint and spline plans (some on robots, some with inline URDFs, 64 distinct ones, twice the URDF
cache, so the LRU eviction runs all the time), Cartesian lines (sampled, bounded deviation,
resolved rate with OSQP) and a few /v1/compare. Its helpers (``start_server``, ``run_load``,
``summarize``, ``worker_pids``, ``rss_mb``) are also used by ``tests/service/test_load.py``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import httpx
import numpy as np
import psutil

REPO = Path(__file__).resolve().parents[1]
LOOPBACK = ("127.0.0.1", "localhost", "::1", "[::1]")
UR5_HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
UR5_GOAL = [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]
PANDA_HOME = [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4]
INLINE_URDFS = 64
"""Distinct inline URDFs in the workload: twice ``TRAJ_URDF_CACHE_SIZE`` (32)."""
LARGEST = {
    "profile": "quintic",
    "start": {"positions": [0.0] * 7},
    "goal": {"positions": [1.0, -0.5, 0.8, -1.2, 0.3, 0.9, -0.7]},
    "duration": 10.0,
    "samples": 100_000,
}
"""The largest response the contract allows for a 7-joint arm: 100,000 points."""
WIDEST = {
    "profile": "quintic",
    "start": {"positions": [0.0] * 64},
    "goal": {"positions": [0.5] * 64},
    "duration": 10.0,
    "samples": 100_000,
}
"""The widest the schema allows: 64 joints, 100,000 points (about 400 MB of JSON)."""


@dataclass
class Request:
    label: str
    method: str
    path: str
    body: Any = None
    expect: tuple[int, ...] = (200,)


@dataclass
class Record:
    label: str
    status: int
    ok: bool
    seconds: float
    finished: float
    error: str = ""


@dataclass
class Server:
    url: str
    process: subprocess.Popen
    log: Path

    @property
    def pid(self) -> int:
        return self.process.pid


@dataclass
class LoadResult:
    records: list[Record] = field(default_factory=list)
    samples: list[tuple[float, int, dict[int, float]]] = field(default_factory=list)
    """RSS samples: (time, requests completed, {worker pid: RSS [MB]})."""
    wall_seconds: float = 0.0
    stopped_early: bool = False


# --- the server ---------------------------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def check_loopback(url: str) -> None:
    host = urlsplit(url).hostname or ""
    if host not in LOOPBACK and not host.startswith("127."):
        raise SystemExit(f"refusing to load {host!r}: only loopback addresses are allowed")


@contextlib.contextmanager
def start_server(
    workers: int = 2, env: dict[str, str] | None = None, timeout_s: float = 60.0
) -> Iterator[Server]:
    """``python -m service`` on 127.0.0.1 and a free port; yields once every worker answers."""
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    environment = {**os.environ, "TRAJ_ACCESS_LOG": "false", "TRAJ_LOG_LEVEL": "warning"}
    environment.update(env or {})
    environment["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(REPO), environment.get("PYTHONPATH", "")) if p
    )
    log = Path(tempfile.mkstemp(prefix="traj-load-", suffix=".log")[1])
    command = [sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port)]
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [*command, "--workers", str(workers)],
            cwd=REPO,
            env=environment,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    server = Server(url, process, log)
    try:
        wait_ready(server, workers, timeout_s)
        yield server
    finally:
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:  # pragma: no cover - a hung server
            process.kill()
            process.wait()
        log.unlink(missing_ok=True)


def wait_ready(server: Server, workers: int, timeout_s: float) -> None:
    """Until ``workers`` worker processes run and /ready answers 200 (each worker loads the robots
    on its first /ready, so ask several times)."""
    deadline = time.monotonic() + timeout_s
    ready = 0
    while time.monotonic() < deadline:
        if server.process.poll() is not None:
            raise RuntimeError(f"the server exited: {server.log.read_text()[-2000:]}")
        try:
            if len(worker_pids(server.pid)) == workers:
                status = httpx.get(server.url + "/ready", timeout=10).status_code
                ready = ready + 1 if status == 200 else 0
                if ready >= 4 * workers:
                    return
                continue
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    raise RuntimeError(f"the server did not get ready in {timeout_s} s")


def worker_pids(master: int) -> list[int]:
    """The uvicorn workers: children of the master that are Python processes (not the
    multiprocessing resource tracker)."""
    try:
        children = psutil.Process(master).children()
    except psutil.NoSuchProcess:
        return []
    pids = []
    for child in children:
        with contextlib.suppress(psutil.Error):
            if "resource_tracker" not in " ".join(child.cmdline()):
                pids.append(child.pid)
    return sorted(pids)


def _status_kb(pid: int, key: str) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return float(line.split()[1])
    raise KeyError(key)


def rss_mb(pid: int) -> float:
    """Resident memory [MB] now (``VmRSS``)."""
    return _status_kb(pid, "VmRSS") / 1024


def peak_rss_mb(pid: int) -> float:
    """Peak resident memory [MB] of the process so far (``VmHWM``)."""
    return _status_kb(pid, "VmHWM") / 1024


# --- the workload -------------------------------------------------------------------------------


def inline_urdf(k: int) -> dict[str, str]:
    """A 3-joint arm whose link lengths depend on ``k``: a distinct model (and cache key) per k."""
    joints = []
    for i, length in enumerate((0.3 + 0.001 * k, 0.25, 0.2)):
        axis = "0 0 1" if i == 0 else "0 1 0"
        joints.append(
            f'<joint name="j{i + 1}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
            f'<origin xyz="0 0 {length}"/><axis xyz="{axis}"/>'
            f'<limit lower="-2.5" upper="2.5" velocity="2" effort="10"/></joint>'
        )
    links = "".join(f'<link name="l{i}"/>' for i in range(4))
    urdf = f'<robot name="arm{k}">{links}{"".join(joints)}</robot>'
    return {"urdf": urdf, "tip_frame": "l3", "base_frame": "l0"}


def _joint(rng: np.random.Generator) -> Request:
    dof = int(rng.integers(2, 8))
    body = {
        "profile": str(rng.choice(["linear", "cubic", "quintic", "trapezoidal"])),
        "start": {"positions": rng.uniform(-2, 2, dof).tolist()},
        "goal": {"positions": rng.uniform(-2, 2, dof).tolist()},
        "limits": {"velocity": [1.5] * dof, "acceleration": [3.0] * dof},
        "samples": int(rng.integers(50, 500)),
    }
    return Request("POST /v1/trajectories/joint", "POST", "/v1/trajectories/joint", body)


def _joint_robot(rng: np.random.Generator) -> Request:
    body = {
        "robot": "ur5",
        "profile": "trapezoidal",
        "start": {"positions": UR5_HOME},
        "goal": {"positions": (np.array(UR5_HOME) + rng.uniform(-0.5, 0.5, 6)).tolist()},
        "sample_period": 0.01,
    }
    return Request("POST /v1/trajectories/joint (ur5)", "POST", "/v1/trajectories/joint", body)


def _joint_inline(rng: np.random.Generator) -> Request:
    body = {
        "robot": inline_urdf(int(rng.integers(INLINE_URDFS))),
        "profile": "quintic",
        "start": {"positions": [0.0, 0.2, -0.2]},
        "goal": {"positions": rng.uniform(-1, 1, 3).tolist()},
        "samples": 100,
    }
    label = "POST /v1/trajectories/joint (inline URDF)"
    return Request(label, "POST", "/v1/trajectories/joint", body)


def _spline(rng: np.random.Generator) -> Request:
    dof, count = int(rng.integers(1, 7)), int(rng.integers(3, 12))
    body = {
        "waypoints": rng.uniform(-2, 2, (count, dof)).tolist(),
        "boundary": str(rng.choice(["clamped", "natural", "not-a-knot"])),
        "limits": {"velocity": [1.0] * dof, "acceleration": [2.0] * dof},
        "samples": int(rng.integers(50, 500)),
    }
    return Request("POST /v1/trajectories/spline", "POST", "/v1/trajectories/spline", body)


def _fk(rng: np.random.Generator) -> Request:
    name, q = str(rng.choice(["ur5", "panda"])), None
    q = np.array(UR5_HOME if name == "ur5" else PANDA_HOME) + rng.uniform(
        -0.3, 0.3, 6 + (name == "panda")
    )
    path = f"/v1/robots/{name}/fk"
    return Request("POST /v1/robots/{name}/fk", "POST", path, {"positions": q.tolist()})


def _ik(rng: np.random.Generator) -> Request:
    body = {
        "pose": {
            "position": [-0.4 + rng.uniform(-0.05, 0.05), -0.11, 0.3 + rng.uniform(-0.05, 0.05)],
            "orientation": [0.7071068, 0.7071068, 0.0, 0.0],
        },
        "seed": UR5_HOME,
    }
    return Request("POST /v1/robots/{name}/ik", "POST", "/v1/robots/ur5/ik", body)


def _cartesian(method: str) -> Any:
    def make(rng: np.random.Generator) -> Request:
        goal = (np.array(UR5_GOAL) + rng.uniform(-0.05, 0.05, 6)).tolist()
        body = {
            "robot": "ur5",
            "method": method,
            "start": {"positions": UR5_HOME},
            "goal": {"positions": goal},
            "samples": 100,
        }
        if method.startswith("resolved_rate"):
            body["control_period"] = 0.004  # 4 ms ticks: a few hundred per line
        label = f"POST /v1/trajectories/cartesian ({method})"
        return Request(label, "POST", "/v1/trajectories/cartesian", body)

    return make


def _compare(rng: np.random.Generator) -> Request:
    task = {
        "robot": "ur5",
        "start": {"positions": UR5_HOME},
        "goal": {"positions": (np.array(UR5_GOAL) + rng.uniform(-0.05, 0.05, 6)).tolist()},
        "samples": 50,
        "control_period": 0.004,
    }
    body = {"task": task, "methods": ["sampled", "bounded_deviation", "resolved_rate_dls"]}
    return Request("POST /v1/compare", "POST", "/v1/compare", body)


MIX: list[tuple[float, Any]] = [
    (0.05, lambda rng: Request("GET /health", "GET", "/health")),
    (0.03, lambda rng: Request("GET /v1/robots", "GET", "/v1/robots")),
    (0.03, lambda rng: Request("GET /v1/robots/{name}", "GET", "/v1/robots/panda")),
    (0.17, _fk),
    (0.10, _ik),
    (0.16, _joint),
    (0.06, _joint_robot),
    (0.06, _joint_inline),
    (0.14, _spline),
    (0.08, _cartesian("sampled")),
    (0.05, _cartesian("bounded_deviation")),
    (0.05, _cartesian("resolved_rate_dls")),
    (0.02, _compare),
]


def build_requests(count: int, seed: int = 2024) -> list[Request]:
    """A fixed, seeded sequence of ``count`` requests drawn from ``MIX``."""
    rng = np.random.default_rng(seed)
    weights = np.array([w for w, _ in MIX])
    picks = rng.choice(len(MIX), size=count, p=weights / weights.sum())
    return [MIX[i][1](rng) for i in picks]


# --- running it ---------------------------------------------------------------------------------


def run_load(
    url: str,
    requests: list[Request],
    *,
    concurrency: int = 4,
    max_seconds: float = 300.0,
    master_pid: int | None = None,
    sample_every_s: float = 0.25,
) -> LoadResult:
    """Send ``requests`` (in order, ``concurrency`` at a time) and stop after ``max_seconds``
    whatever happens; sample the workers' RSS meanwhile when ``master_pid`` is given."""
    check_loopback(url)
    result = LoadResult()
    lock = threading.Lock()
    started = time.monotonic()
    stop = threading.Event()
    local = threading.local()
    cursor = iter(range(len(requests)))

    def client() -> httpx.Client:
        if not hasattr(local, "client"):
            local.client = httpx.Client(base_url=url, timeout=60.0)
        return local.client

    def worker() -> None:
        while not stop.is_set():
            with lock:
                i = next(cursor, None)
            if i is None:
                return
            if time.monotonic() - started > max_seconds:
                result.stopped_early = True
                stop.set()
                return
            req = requests[i]
            t0 = time.perf_counter()
            try:
                response = client().request(req.method, req.path, json=req.body)
                status, error = response.status_code, ""
                if status not in req.expect:
                    error = response.text[:300]
            except httpx.HTTPError as e:
                status, error = 0, f"{type(e).__name__}: {e}"
                local.__dict__.pop("client", None)
            elapsed = time.perf_counter() - t0
            record = Record(
                req.label, status, status in req.expect, elapsed, time.monotonic(), error
            )
            with lock:
                result.records.append(record)

    def sampler() -> None:
        while not stop.wait(sample_every_s):
            if master_pid is None:
                return
            rss = {}
            for pid in worker_pids(master_pid):
                with contextlib.suppress(OSError, KeyError):
                    rss[pid] = rss_mb(pid)
            with lock:
                done = len(result.records)
            result.samples.append((time.monotonic(), done, rss))

    sampling = threading.Thread(target=sampler, daemon=True)
    sampling.start()
    with ThreadPoolExecutor(max_workers=concurrency) as pool:
        for future in [pool.submit(worker) for _ in range(concurrency)]:
            future.result()
    stop.set()
    sampling.join(timeout=5)
    result.wall_seconds = time.monotonic() - started
    return result


def percentile_ms(seconds: list[float], q: float) -> float:
    return float(np.percentile(np.array(seconds) * 1e3, q)) if seconds else float("nan")


def summarize(records: list[Record]) -> dict[str, dict[str, float]]:
    """Per label: count, errors, p50/p99/max latency [ms]; plus an ``all`` row."""
    out: dict[str, dict[str, float]] = {}
    labels = [*sorted({r.label for r in records}), "all"]
    for label in labels:
        rows = [r for r in records if label in ("all", r.label)]
        times = [r.seconds for r in rows]
        out[label] = {
            "count": len(rows),
            "errors": sum(not r.ok for r in rows),
            "p50_ms": percentile_ms(times, 50),
            "p99_ms": percentile_ms(times, 99),
            "max_ms": max(times) * 1e3 if times else float("nan"),
        }
    return out


def rss_window(result: LoadResult, first: int, last: int) -> dict[int, float]:
    """Mean RSS [MB] of each worker over the samples taken while requests ``first``..``last``
    completed."""
    sums: dict[int, list[float]] = {}
    for _, done, rss in result.samples:
        if first <= done <= last:
            for pid, mb in rss.items():
                sums.setdefault(pid, []).append(mb)
    return {pid: float(np.mean(v)) for pid, v in sums.items()}


def memory_growth(result: LoadResult, warmup: int, window: int = 1000) -> dict[str, Any]:
    """RSS during the first and the last ``window`` requests after ``warmup``, per worker."""
    n = len(result.records)
    early = rss_window(result, warmup, warmup + window)
    late = rss_window(result, n - window, n)
    growth = {pid: late[pid] / early[pid] - 1.0 for pid in early if pid in late}
    return {"first_mb": early, "last_mb": late, "growth": growth}


def largest_response(server: Server, body: dict[str, Any]) -> dict[str, Any]:
    """Serve ``body`` (a 100,000-point joint plan) and report size, time and the workers' peaks."""
    before = {pid: peak_rss_mb(pid) for pid in worker_pids(server.pid)}
    t0 = time.perf_counter()
    with httpx.Client(base_url=server.url, timeout=120.0) as c:
        response = c.post("/v1/trajectories/joint", json=body)
    seconds = time.perf_counter() - t0
    after = {pid: peak_rss_mb(pid) for pid in worker_pids(server.pid)}
    points = response.content.count(b'"time_from_start"') if response.status_code == 200 else 0
    return {
        "status": response.status_code,
        "points": points,
        "joints": len(body["start"]["positions"]),
        "bytes": len(response.content),
        "seconds": seconds,
        "peak_before_mb": before,
        "peak_after_mb": after,
        "peak_mb": max(after.values()),
    }


# --- command line -------------------------------------------------------------------------------


def _table(summary: dict[str, dict[str, float]]) -> str:
    lines = [
        "| endpoint | requests | errors | p50 [ms] | p99 [ms] | max [ms] |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for label, row in summary.items():
        lines.append(
            f"| {label} | {row['count']:.0f} | {row['errors']:.0f} | {row['p50_ms']:.1f} | "
            f"{row['p99_ms']:.1f} | {row['max_ms']:.0f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.load", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--requests", type=int, default=6000)
    parser.add_argument("--warmup", type=int, default=500)
    parser.add_argument("--concurrency", type=int, default=4)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--max-seconds", type=float, default=300.0)
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--json", type=Path, help="write the figures here as JSON")
    args = parser.parse_args(argv)
    requests = build_requests(args.requests, args.seed)
    with start_server(args.workers) as server:
        workers = worker_pids(server.pid)
        idle = {pid: rss_mb(pid) for pid in workers}
        print(f"server {server.url}, workers {workers}, idle RSS [MB] {idle}", flush=True)
        result = run_load(
            server.url,
            requests,
            concurrency=args.concurrency,
            max_seconds=args.max_seconds,
            master_pid=server.pid,
        )
        summary = summarize(result.records)
        memory = memory_growth(result, args.warmup)
        under_load = {pid: max(s[2].get(pid, 0.0) for s in result.samples) for pid in workers}
        largest = largest_response(server, LARGEST)
        widest = largest_response(server, WIDEST)
    done = len(result.records)
    print(f"{done} requests in {result.wall_seconds:.1f} s ({done / result.wall_seconds:.1f}/s)")
    print(_table(summary))
    print("RSS [MB] idle:", {p: round(v) for p, v in idle.items()})
    print("RSS [MB] max under load:", {p: round(v) for p, v in under_load.items()})
    print("RSS [MB] first/last 1000 after warm-up:", memory)
    for name, big in (("largest (7 joints)", largest), ("widest (64 joints)", widest)):
        print(
            f"{name}: {big['status']} {big['points']} points, {big['bytes'] / 1e6:.0f} MB, "
            f"{big['seconds']:.2f} s, worker peak RSS {big['peak_mb']:.0f} MB"
        )
    errors = [r for r in result.records if not r.ok]
    for r in errors[:10]:
        print("ERROR", r.label, r.status, r.error)
    if args.json:
        figures = {
            "requests": done,
            "seconds": result.wall_seconds,
            "summary": summary,
            "idle_mb": idle,
            "under_load_max_mb": under_load,
            "memory": memory,
            "largest": largest,
            "widest": widest,
        }
        args.json.write_text(json.dumps(figures, indent=2, default=str))
    return 1 if errors or result.stopped_early else 0


if __name__ == "__main__":
    raise SystemExit(main())
