"""Operations: /health, /ready, /metrics, request ids, JSON logs, settings, several workers."""

from __future__ import annotations

import io
import json
import logging
import math
import os
import re
import socket
import subprocess
import sys
import time
import types
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from fastapi import APIRouter
from fastapi.testclient import TestClient
from prometheus_client.parser import text_string_to_metric_families

from core import errors as ex
from service.__main__ import multiprocess_metrics_dir
from service.app import create_app
from service.middleware.logging_setup import (
    JsonFormatter,
    TextFormatter,
    log_config,
    request_id_from,
)
from service.settings import Settings, SettingsError, env_names

REPO = Path(__file__).resolve().parents[2]
TEMPLATE = "/_ops_test/items/{item}"
HEX32 = re.compile(r"[0-9a-f]{32}")


def _app():
    app = create_app(Settings())
    test_log = logging.getLogger("service.test_ops")

    def item(
        item: str,
    ) -> dict[str, str]:  # plain def: runs in the thread pool, like planning routes
        test_log.info("inside the route")
        return {"item": item}

    def unreachable() -> None:
        raise ex.Unreachable("no IK solution at s=0.5", s=0.5)

    app.add_api_route(TEMPLATE, item, methods=["GET"])
    app.add_api_route("/_ops_test/unreachable", unreachable, methods=["GET"])
    app.add_api_route("/_ops_test/upload/{name}", lambda name: {"name": name}, methods=["POST"])
    own_prefix = APIRouter(prefix="/_ops_test/own")  # how the resource routers are written
    own_prefix.add_api_route("/{name}/fk", lambda name: {"name": name}, methods=["GET"])
    app.include_router(own_prefix)
    include_prefix = APIRouter()
    include_prefix.add_api_route("/{name}", lambda name: {"name": name}, methods=["GET"])
    app.include_router(include_prefix, prefix="/_ops_test/included")
    return app


@pytest.fixture()
def client() -> TestClient:
    return TestClient(_app())


def scrape(text: str) -> dict[tuple[str, frozenset], float]:
    return {
        (s.name, frozenset(s.labels.items())): s.value
        for family in text_string_to_metric_families(text)
        for s in family.samples
    }


def value(samples: dict, name: str, **labels: str) -> float:
    return samples.get((name, frozenset(labels.items())), 0.0)


# ----------------------------------------------------------------------------- health and ready


def test_health_is_cheap_and_ok(client: TestClient) -> None:
    r = client.get("/health")
    assert r.status_code == 200
    assert r.json()["status"] == "ok"


class FakeRobot:
    """A planar 2-link arm (links l1, l2 in [m]) with the Robot interface /ready uses."""

    def __init__(self, l1: float = 1.0, l2: float = 0.8, broken: bool = False) -> None:
        self.l1, self.l2, self.broken = l1, l2, broken
        self.dof = 2
        self.home = [0.3, -0.2]

    def fk(self, q: np.ndarray) -> np.ndarray:
        if self.broken:
            return np.full((4, 4), np.nan)
        a, b = float(q[0]), float(q[0] + q[1])
        T = np.eye(4)
        T[:2, :2] = [[math.cos(b), -math.sin(b)], [math.sin(b), math.cos(b)]]
        T[0, 3] = self.l1 * math.cos(a) + self.l2 * math.cos(b)
        T[1, 3] = self.l1 * math.sin(a) + self.l2 * math.sin(b)
        return T


def fake_registry(robots: dict[str, FakeRobot]) -> types.ModuleType:
    module = types.ModuleType("robots.registry")
    module.calls = 0  # type: ignore[attr-defined]

    def names() -> list[str]:
        module.calls += 1  # type: ignore[attr-defined]
        return list(robots)

    module.names = names  # type: ignore[attr-defined]
    module.get = robots.__getitem__  # type: ignore[attr-defined]
    return module


def test_ready_passes_and_caches(client: TestClient, monkeypatch: pytest.MonkeyPatch) -> None:
    registry = fake_registry({"planar_2r": FakeRobot(), "other": FakeRobot(0.5, 0.5)})
    monkeypatch.setitem(sys.modules, "robots.registry", registry)
    for _ in range(3):
        r = client.get("/ready")
        assert r.status_code == 200
        assert r.json() == {"status": "ready", "robots": ["other", "planar_2r"]}
    assert registry.calls == 1  # the first success is cached


@pytest.mark.parametrize(
    ("robots", "needle"),
    [
        ({"planar_2r": FakeRobot(1.0, 0.7)}, "self-test"),
        ({"planar_2r": FakeRobot(), "bad": FakeRobot(broken=True)}, "'bad'"),
        ({}, "no robot"),
    ],
)
def test_ready_is_503_problem_until_the_self_test_passes(
    client: TestClient, monkeypatch: pytest.MonkeyPatch, robots: dict, needle: str
) -> None:
    monkeypatch.setitem(sys.modules, "robots.registry", fake_registry(robots))
    r = client.get("/ready")
    assert r.status_code == 503
    assert r.headers["content-type"] == "application/problem+json"
    assert r.headers["retry-after"].isdigit()
    body = r.json()
    assert body["code"] == "not_ready" and body["status"] == 503
    assert needle in body["detail"]
    # Fixed: the next probe succeeds (a failure is never cached).
    monkeypatch.setitem(sys.modules, "robots.registry", fake_registry({"planar_2r": FakeRobot()}))
    assert client.get("/ready").status_code == 200


def test_ready_without_a_robot_registry_is_503(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "robots.registry", None)  # import raises ImportError
    r = client.get("/ready")
    assert r.status_code == 503 and r.json()["code"] == "not_ready"


@pytest.mark.skipif(
    not (REPO / "robots" / "registry.py").exists(), reason="robots/registry.py not written yet"
)
def test_ready_with_the_real_robots(client: TestClient) -> None:
    r = client.get("/ready")
    assert r.status_code == 200, r.text
    assert "planar_2r" in r.json()["robots"]


# ----------------------------------------------------------------------------- metrics


def test_request_counter_and_histogram_use_the_route_template(client: TestClient) -> None:
    before = scrape(client.get("/metrics").text)
    for item in ("abc", "def"):
        assert client.get(f"/_ops_test/items/{item}").status_code == 200
    r = client.get("/metrics")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/plain")
    after = scrape(r.text)
    labels = {"route": TEMPLATE, "method": "GET", "status": "200"}
    assert value(after, "http_requests_total", **labels) - value(
        before, "http_requests_total", **labels
    ) == pytest.approx(2)
    count = "http_request_duration_seconds_count"
    assert value(after, count, **labels) - value(before, count, **labels) == pytest.approx(2)
    routes = {dict(k[1]).get("route") for k in after}
    assert not any(r and ("abc" in r or "def" in r) for r in routes)  # never the raw path
    assert any(name.startswith("process_") for name, _ in after)


@pytest.mark.parametrize(
    ("method", "path", "template", "status"),
    [
        ("GET", "/_ops_test/own/ur5/fk", "/_ops_test/own/{name}/fk", 200),
        ("GET", "/_ops_test/included/ur5", "/_ops_test/included/{name}", 200),
        ("DELETE", "/_ops_test/items/7", TEMPLATE, 405),
        ("POST", "/_ops_test/upload/big", "/_ops_test/upload/{name}", 413),  # body limit answers
    ],
)
def test_route_label_is_the_full_template(
    client: TestClient, method: str, path: str, template: str, status: int
) -> None:
    labels = {"route": template, "method": method, "status": str(status)}
    before = value(scrape(client.get("/metrics").text), "http_requests_total", **labels)
    body = b"x" * (3 * 1024 * 1024) if status == 413 else None
    assert client.request(method, path, content=body).status_code == status
    after = value(scrape(client.get("/metrics").text), "http_requests_total", **labels)
    assert after - before == pytest.approx(1)


def test_unrouted_paths_share_one_label(client: TestClient) -> None:
    client.get("/no/such/path/12345")
    samples = scrape(client.get("/metrics").text)
    assert value(samples, "http_requests_total", route="unmatched", method="GET", status="404") >= 1
    assert not any("12345" in str(k) for k in samples)


def test_planning_failures_are_counted_by_code(client: TestClient) -> None:
    name = "planning_failures_total"
    before = value(scrape(client.get("/metrics").text), name, code="unreachable")
    r = client.get("/_ops_test/unreachable")
    assert r.status_code == 422 and r.json()["code"] == "unreachable"
    after = scrape(client.get("/metrics").text)
    assert value(after, name, code="unreachable") - before == pytest.approx(1)
    assert (name, frozenset({("code", "time_budget_exceeded")})) in after  # every code exported


def test_metrics_stays_out_of_the_api_schema(client: TestClient) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    assert "/ready" in paths and "/metrics" not in paths


# ----------------------------------------------------------------------------- request ids, logs


def test_request_id_is_echoed_or_generated(client: TestClient) -> None:
    assert (
        client.get("/health", headers={"X-Request-ID": "abc-1.2_X"}).headers["x-request-id"]
        == "abc-1.2_X"
    )
    for bad in ("has space", "x" * 129, 'quote"', "é"):
        rid = client.get("/health", headers={"X-Request-ID": bad.encode()})
        assert HEX32.fullmatch(rid.headers["x-request-id"]), bad
    assert HEX32.fullmatch(client.get("/health").headers["x-request-id"])
    too_large = client.post("/v1/anything", content=b"x" * (3 * 1024 * 1024))
    assert too_large.status_code == 413 and "x-request-id" in too_large.headers
    assert request_id_from("x" * 128) == "x" * 128


def test_every_log_line_is_json_with_the_request_id(client: TestClient) -> None:
    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    handler.setFormatter(JsonFormatter())
    logger = logging.getLogger("service")
    old_level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        r = client.get("/_ops_test/items/42", headers={"X-Request-ID": "log-test-1"})
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old_level)
    assert r.status_code == 200
    lines = [json.loads(line) for line in stream.getvalue().splitlines()]
    assert lines and all(line["request_id"] == "log-test-1" for line in lines)
    inside = next(line for line in lines if line["logger"] == "service.test_ops")
    assert inside["msg"] == "inside the route" and inside["level"] == "info"
    access = next(line for line in lines if line["logger"] == "service.access")
    assert access["route"] == TEMPLATE and access["status"] == 200 and access["method"] == "GET"
    assert access["duration_ms"] >= 0 and access["ts"].endswith("Z")


def test_text_format_for_a_terminal() -> None:
    record = logging.LogRecord("service.x", logging.WARNING, __file__, 1, "hi %s", ("there",), None)
    record.request_id = "r-1"
    line = TextFormatter().format(record)
    assert line.endswith("warning service.x [r-1] hi there")


def test_log_config_is_a_valid_dict_config() -> None:
    config = log_config("debug", "json")
    assert config["formatters"]["default"]["()"] == "service.middleware.logging_setup.JsonFormatter"
    assert config["root"]["level"] == "DEBUG"
    assert log_config("info", "text")["formatters"]["default"]["()"].endswith("TextFormatter")


# ----------------------------------------------------------------------------- settings


def test_settings_come_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name, raw in {
        "WORKERS": "3",
        "PORT": "9000",
        "HOST": "0.0.0.0",
        "TIME_BUDGET_S": "2.5",
        "LOG_LEVEL": "WARNING",
        "ACCESS_LOG": "false",
        "MAX_BODY_BYTES": "1024",
    }.items():
        monkeypatch.setenv(f"TRAJ_{name}", raw)
    s = Settings.from_env()
    assert (s.workers, s.port, s.host, s.time_budget_s) == (3, 9000, "0.0.0.0", 2.5)
    assert (s.log_level, s.access_log, s.max_body_bytes) == ("warning", False, 1024)
    for name, raw in [
        ("WORKERS", "0"),
        ("PORT", "http"),
        ("TIME_BUDGET_S", "nan"),
        ("LOG_LEVEL", "x"),
    ]:
        monkeypatch.setenv(f"TRAJ_{name}", raw)
        with pytest.raises(SettingsError, match=f"TRAJ_{name}"):
            Settings.from_env()
        monkeypatch.delenv(f"TRAJ_{name}")


def test_readme_documents_every_setting() -> None:
    readme = (REPO / "README.md").read_text()
    assert "## Configuration" in readme
    section = readme.split("## Configuration", 1)[1].split("\n## ", 1)[0]
    missing = [name for name in env_names() if f"`{name}`" not in section]
    assert not missing, f"README Configuration table lacks {missing}"


def test_multiprocess_dir_is_created_and_removed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("PROMETHEUS_MULTIPROC_DIR", raising=False)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    with multiprocess_metrics_dir(1) as path:
        assert path is None
    with multiprocess_metrics_dir(2) as path:
        assert path and Path(path).is_dir() and os.environ["PROMETHEUS_MULTIPROC_DIR"] == path
    assert not Path(path).exists() and "PROMETHEUS_MULTIPROC_DIR" not in os.environ
    given = tmp_path / "given"
    given.mkdir()
    (given / "counter_1.db").write_bytes(b"stale")
    monkeypatch.setenv("PROMETHEUS_MULTIPROC_DIR", str(given))
    with multiprocess_metrics_dir(4) as path:
        assert path == str(given) and not list(given.iterdir())
    assert given.is_dir()  # the caller's directory stays


# ----------------------------------------------------------------------------- several workers


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(url: str, request_id: str | None = None) -> tuple[int, str]:
    headers = {"X-Request-ID": request_id} if request_id else {}
    with urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=5) as r:
        return r.status, r.read().decode()


def test_two_workers_export_one_sum(tmp_path: Path) -> None:
    """`python -m service --workers 2`: /metrics sums both workers, logs are JSON, dir cleaned."""
    port = _free_port()
    base = f"http://127.0.0.1:{port}"
    env = {**os.environ, "TMPDIR": str(tmp_path), "TRAJ_LOG_LEVEL": "info"}
    env.pop("PROMETHEUS_MULTIPROC_DIR", None)
    log_path = tmp_path / "server.log"
    with log_path.open("wb") as log_file:
        proc = subprocess.Popen(
            [sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port),
             "--workers", "2"],
            cwd=REPO, env=env, stdout=log_file, stderr=subprocess.STDOUT,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + 20
            while True:
                try:
                    _get(f"{base}/metrics")
                    break
                except (urllib.error.URLError, ConnectionError):
                    assert proc.poll() is None, log_path.read_text()
                    assert time.monotonic() < deadline, "server did not start"
                    time.sleep(0.1)
            n = 24
            for i in range(n):
                assert _get(f"{base}/health", f"mp-{i}")[0] == 200
            while True:  # until both workers have imported the app and written their files
                samples = scrape(_get(f"{base}/metrics")[1])
                pids = {
                    dict(labels)["pid"]
                    for name, labels in samples
                    if name == "process_resident_memory_bytes"
                }
                if len(pids) >= 2 or time.monotonic() > deadline:
                    break
                time.sleep(0.1)
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:  # pragma: no cover - a hung server
                proc.kill()
                proc.wait(timeout=5)
    labels = {"route": "/health", "method": "GET", "status": "200"}
    assert value(samples, "http_requests_total", **labels) == n
    assert value(samples, "http_request_duration_seconds_count", **labels) == n
    assert len(pids) == 2, "process metrics should name both workers"
    assert not list(tmp_path.glob("traj-metrics-*")), "multiprocess directory left behind"
    records = []
    for line in log_path.read_text().splitlines():
        if line.startswith("{"):
            records.append(json.loads(line))
    ids = {r.get("request_id") for r in records if r["logger"] == "service.access"}
    assert {f"mp-{i}" for i in range(n)} <= ids
