"""Prometheus metrics at ``GET /metrics``: requests, latency, planning failures, process figures.

Series (``route`` is the route template such as ``/v1/robots/{name}``, never the raw path, so the
label set stays bounded; a path no route matches is ``unmatched``):

- ``http_requests_total{route, method, status}``
- ``http_request_duration_seconds{route, method, status}`` (histogram, ``BUCKETS`` in [s])
- ``http_requests_in_progress``
- ``planning_failures_total{code}`` (one per problem+json answer of a planning error)
- ``process_*`` (CPU seconds, resident memory, open fds, start time)

Several workers: with ``PROMETHEUS_MULTIPROC_DIR`` set *before this module is imported* (``python -m
service --workers N`` does it), prometheus_client keeps each worker's values in memory-mapped files
in that directory and whichever worker answers the scrape sums them all (multiprocess mode).
Process metrics then come from ``/proc`` of every live worker, labelled with its ``pid``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

from fastapi import APIRouter
from prometheus_client import (
    REGISTRY,
    CollectorRegistry,
    Counter,
    Gauge,
    Histogram,
    disable_created_metrics,
    generate_latest,
)
from prometheus_client.metrics_core import Metric
from prometheus_client.multiprocess import MultiProcessCollector, mark_process_dead
from prometheus_client.process_collector import ProcessCollector
from prometheus_client.registry import Collector
from starlette.responses import Response

from core import errors as ex

MULTIPROC_DIR = os.environ.get("PROMETHEUS_MULTIPROC_DIR") or None
"""Multiprocess mode is decided once, at import, exactly as prometheus_client decides it."""

BUCKETS = (0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0)
"""Latency buckets in [s]: sub-millisecond FK up to the 10 s planning budget and beyond."""

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"
"""The classic text format, which every Prometheus version scrapes."""

METHODS = frozenset({"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS"})
UNMATCHED = "unmatched"

disable_created_metrics()  # no ``*_created`` series: half the lines, nothing a dashboard needs

REQUESTS = Counter("http_requests_total", "HTTP requests answered.", ["route", "method", "status"])
LATENCY = Histogram(
    "http_request_duration_seconds",
    "Time from request start to the end of the response, in seconds.",
    ["route", "method", "status"],
    buckets=BUCKETS,
)
IN_PROGRESS = Gauge(
    "http_requests_in_progress", "HTTP requests being served.", multiprocess_mode="livesum"
)
PLANNING_FAILURES = Counter(
    "planning_failures_total",
    "Planning errors answered as problem+json, by error code.",
    ["code"],
)

_children: dict[tuple[str, str, str], tuple[Counter, Histogram]] = {}


def _planning_codes() -> set[str]:
    codes, todo = set(), [ex.PlanningError]
    while todo:
        cls = todo.pop()
        codes.add(cls.code)
        todo.extend(cls.__subclasses__())
    return codes


# Every code has a series from the start (at 0), so rate() sees the first failure too.
for _code in sorted(_planning_codes()):
    PLANNING_FAILURES.labels(code=_code)


def observe_request(route: str, method: str, status: int, seconds: float) -> None:
    """Count one answered request and its duration in [s] (label children cached per key)."""
    key = (route, method if method in METHODS else "other", str(status))
    pair = _children.get(key)
    if pair is None:
        pair = _children.setdefault(key, (REQUESTS.labels(*key), LATENCY.labels(*key)))
    pair[0].inc()
    pair[1].observe(seconds)


def planning_failure(code: str) -> None:
    """Count one planning error answered to a client (called by ``service.errors``)."""
    PLANNING_FAILURES.labels(code=code).inc()


class WorkerProcessCollector(Collector):
    """``process_*`` metrics of every live worker that writes to ``path``, with a ``pid`` label.

    Workers are found by the pid in the names of their files (``counter_1234.db``). A pid that no
    longer exists has its live-gauge files removed (``mark_process_dead``), so
    ``http_requests_in_progress`` forgets a worker that died; its counters are kept, as they should.
    """

    def __init__(self, path: str) -> None:
        self._path = path
        self._pid = 0
        self._process = ProcessCollector(pid=lambda: self._pid, registry=None)

    def _pids(self) -> set[int]:
        pids = set()
        for name in os.listdir(self._path):
            stem, _, tail = name.rpartition("_")
            if stem and tail.endswith(".db") and tail[:-3].isdigit():
                pids.add(int(tail[:-3]))
        return pids

    def collect(self) -> Iterator[Metric]:
        families: dict[str, Metric] = {}
        for pid in sorted(self._pids()):
            if not _alive(pid):
                mark_process_dead(pid, self._path)
                continue
            self._pid = pid
            for metric in self._process.collect():
                family = families.setdefault(
                    metric.name, Metric(metric.name, metric.documentation, metric.type)
                )
                for s in metric.samples:
                    family.add_sample(s.name, {**s.labels, "pid": str(pid)}, s.value)
        yield from families.values()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def exposition() -> bytes:
    """The text exposition of every metric (summed over workers in multiprocess mode)."""
    if MULTIPROC_DIR is None:
        return generate_latest(REGISTRY)
    registry = CollectorRegistry()
    MultiProcessCollector(registry, path=MULTIPROC_DIR)
    registry.register(WorkerProcessCollector(MULTIPROC_DIR))
    return generate_latest(registry)


router = APIRouter(tags=["operations"])


@router.get("/metrics", include_in_schema=False)
def metrics() -> Response:
    """Prometheus text format 0.0.4."""
    return Response(exposition(), media_type=CONTENT_TYPE)
