"""The measuring machinery of ``python -m bench``: rows, alternating rounds, tables, a live server.

Every task is a ``Table`` of ``Row``s, each a callable doing the whole task once (ours through the
core function, ours through HTTP, a peer library, a plain reference). ``measure`` runs the rows
alternately: each round calls every row ``reps`` times in a row (a rotating order, so no row always
follows the same neighbour), with the garbage collector off inside a row's batch and collected
between batches, until ``rounds`` rounds are done or the time budget is spent. The median and the
95th percentile are over every call of every round; the ratio is a row's median over the median of
the table's reference row (below 1: faster than the reference).

A row whose package is not installed is listed as ``unavailable`` and never fails the run; a row
that raises is listed with its error and makes ``python -m bench`` exit non-zero at the end. Timings
never fail anything.
"""

from __future__ import annotations

import contextlib
import gc
import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


@dataclass
class Row:
    """One contender of a task.

    Attributes:
        name: What runs, as printed (``ours: core ...``, ``ours: HTTP ...``, a peer's call).
        fn: Does the whole task once; ``None`` when ``unavailable`` says why.
        unavailable: Why the row cannot run (a package not installed), else empty.
        note: Printed beside the times (accuracy, what the call includes).
        extra: Values of the table's extra columns (``Table.columns``), by column name.
        peer: True for another library's row (an exception there is reported, not raised).
    """

    name: str
    fn: Callable[[], object] | None = None
    unavailable: str = ""
    note: str = ""
    extra: dict[str, str] = field(default_factory=dict)
    peer: bool = False
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    error: str = ""

    @property
    def median(self) -> float:
        return float(np.median(self.times)) if self.times.size else float("nan")

    @property
    def p95(self) -> float:
        return float(np.percentile(self.times, 95)) if self.times.size else float("nan")


@dataclass
class Table:
    """One task's rows and how to print them.

    Attributes:
        key: ``P1`` ... ``P6``.
        title: One line: the task.
        reference: Name of the row every ratio divides by.
        rows: The contenders.
        columns: Extra columns (each row's ``extra``), after the times.
        notes: Lines printed under the table.
        unit: ``us`` or ``ms`` for the time columns.
    """

    key: str
    title: str
    reference: str
    rows: list[Row]
    columns: tuple[str, ...] = ()
    notes: list[str] = field(default_factory=list)
    unit: str = "us"

    @property
    def errors(self) -> list[str]:
        return [f"{self.key} {r.name}: {r.error}" for r in self.rows if r.error]

    def markdown(self) -> list[str]:
        scale = 1e6 if self.unit == "us" else 1e3
        ref = next((r for r in self.rows if r.name == self.reference), None)
        ref_median = ref.median if ref is not None else float("nan")
        head = f"| {self.key} | median [{self.unit}] | p95 [{self.unit}] | ratio | calls |"
        head += "".join(f" {c} |" for c in self.columns) + " note |"
        lines = [f"### {self.key}: {self.title}", "", head]
        lines.append("|---|" + "---:|" * 4 + "---:|" * len(self.columns) + "---|")
        for r in self.rows:
            extra = "".join(f" {r.extra.get(c, '')} |" for c in self.columns)
            if r.unavailable or r.error:
                what = r.unavailable or f"error: {r.error}"
                lines.append(f"| {r.name} | {what} | | | |{extra} {r.note} |")
                continue
            ratio = r.median / ref_median if np.isfinite(ref_median) else float("nan")
            name = f"**{r.name}**" if r.name == self.reference else r.name
            lines.append(
                f"| {name} | {_fmt(r.median * scale)} | {_fmt(r.p95 * scale)} | "
                f"{ratio:.2f}x | {r.times.size} |{extra} {r.note} |"
            )
        lines += [""] + [f"- {n}" for n in self.notes] + ([""] if self.notes else [])
        return lines


def _fmt(x: float) -> str:
    if not np.isfinite(x):
        return "-"
    return f"{x:.0f}" if x >= 100 else f"{x:.1f}" if x >= 10 else f"{x:.2f}"


@dataclass(frozen=True)
class Budget:
    """How long to measure each table: ``rounds`` rounds of ``batch_s`` seconds per row, stopping
    early (after at least ``min_rounds``) once ``table_s`` seconds are spent."""

    rounds: int
    batch_s: float
    table_s: float
    min_rounds: int = 3


FULL = Budget(rounds=15, batch_s=0.05, table_s=60.0)
QUICK = Budget(rounds=3, batch_s=0.01, table_s=8.0, min_rounds=2)


def measure(table: Table, budget: Budget) -> Table:
    """Time every runnable row of ``table`` in alternating rounds (see the module docstring)."""
    live = []
    for row in table.rows:
        if row.fn is None:
            continue
        try:
            start = time.perf_counter()
            row.fn()  # warm-up: imports, caches, workspaces; its time is not counted
            first = time.perf_counter() - start
        except Exception as e:  # reported in the table; makes the run exit non-zero
            row.error = f"{type(e).__name__}: {e}"[:200]
            if not row.peer:
                raise
            continue
        reps = int(np.clip(budget.batch_s / max(first, 1e-7), 1, 2000))
        live.append((row, reps, []))
    started = time.perf_counter()
    for k in range(budget.rounds):
        shift = k % max(len(live), 1)
        for row, reps, samples in live[shift:] + live[:shift]:
            gc.collect()
            gc.disable()
            try:
                for _ in range(reps):
                    t0 = time.perf_counter()
                    row.fn()  # type: ignore[misc]
                    samples.append(time.perf_counter() - t0)
            finally:
                gc.enable()
        if k + 1 >= budget.min_rounds and time.perf_counter() - started > budget.table_s:
            break
    for row, _, samples in live:
        row.times = np.asarray(samples)
    return table


def optional(module: str) -> str:
    """Empty when ``module`` imports, else ``unavailable (...)`` naming it: rows of peers use it."""
    try:
        __import__(module)
    except Exception as e:
        return f"unavailable ({type(e).__name__}: {e})"[:160]
    return ""


# --- a live server on loopback --------------------------------------------------------------------


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class LiveServer(NamedTuple):
    """A running ``python -m service``: its base URL and the id of the process started."""

    url: str
    pid: int


def cpu_seconds(pid: int) -> float:
    """User + system CPU time [s] of process ``pid`` and its descendants (Linux ``/proc``; 0 when
    unreadable)."""
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    total, todo = 0.0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open(f"/proc/{p}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as f:
                    todo += [int(c) for c in f.read().split()]
        except (OSError, ValueError, IndexError):
            continue
    return total


@contextlib.contextmanager
def server(workers: int = 1, timeout_s: float = 60.0) -> Iterator[LiveServer]:
    """``python -m service`` on 127.0.0.1 at a free port with ``workers`` processes; yields its URL
    and process id once ``/ready`` answers; stops the process it started (by its id) on exit."""
    import httpx

    port = free_port()
    env = dict(os.environ, TRAJ_ACCESS_LOG="false", TRAJ_LOG_LEVEL="warning")
    cmd = [sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port)]
    cmd += ["--workers", str(workers), "--log-level", "warning"]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            if proc.poll() is not None:
                err = proc.stderr.read().decode(errors="replace")[-2000:] if proc.stderr else ""
                raise RuntimeError(f"the service exited with {proc.returncode}: {err}")
            try:
                # every worker loads the robots at its first /ready; ask a few times
                if all(httpx.get(f"{url}/ready", timeout=10).status_code == 200 for _ in range(4)):
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"the service did not become ready within {timeout_s:g} s")
            time.sleep(0.2)
        yield LiveServer(url, proc.pid)
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)
        if proc.stderr:
            proc.stderr.close()


def http_row(client, url: str, path: str, body: dict, name: str, note: str = "") -> Row:
    """A row posting ``body`` (pre-encoded JSON) and decoding the answer: one full round trip."""
    import orjson

    content = orjson.dumps(body)
    headers = {"content-type": "application/json"}

    def call() -> object:
        r = client.post(f"{url}{path}", content=content, headers=headers)
        if r.status_code != 200:
            raise RuntimeError(f"HTTP {r.status_code}: {r.text[:300]}")
        return orjson.loads(r.content)

    return Row(name, call, note=note or "httpx, keep-alive, orjson decode included")
