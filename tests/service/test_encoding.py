"""The encoding of trajectory documents: the streamed body of a large one is byte-identical to the
one-shot one, ``?layout=columns`` carries exactly the numbers of the default layout, and the size
estimate used for admission bounds the encoded size."""

from __future__ import annotations

import asyncio

import numpy as np
import orjson
import pytest
from fastapi.testclient import TestClient

from core.trajectory import Trajectory
from service import encoding
from service.app import create_app
from service.encoding import JSON_OPTIONS, STREAM_POINTS, json_response, trajectory_body
from service.settings import Settings


def _body(n: int, time_format: str) -> dict:
    rng = np.random.default_rng(n)
    t = np.linspace(0.0, 3.0, n)
    q = rng.normal(size=(n, 3))
    traj = Trajectory(t, q, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)))
    return trajectory_body(traj, {"method": "test", "warnings": []}, time_format, knots=[1, 2])


async def _collect(response) -> bytes:
    parts = [chunk async for chunk in response.body_iterator]
    return b"".join(p if isinstance(p, bytes) else p.encode() for p in parts)


@pytest.mark.parametrize("n", [STREAM_POINTS + 1, 2 * STREAM_POINTS, 3 * STREAM_POINTS + 7])
@pytest.mark.parametrize("time_format", ["float", "ros"])
def test_streamed_body_equals_one_shot(n, time_format, monkeypatch):
    monkeypatch.setattr(encoding, "STREAM_BYTES", 0)
    body = _body(n, time_format)
    response = json_response(body)
    assert not hasattr(response, "body")  # streamed
    streamed = asyncio.run(_collect(response))
    assert streamed == orjson.dumps(body, option=JSON_OPTIONS)
    assert len(orjson.loads(streamed)["points"]) == n


def test_small_body_is_one_shot():
    body = _body(10, "float")
    assert json_response(body).body == orjson.dumps(body, option=JSON_OPTIONS)


def test_streaming_starts_above_stream_bytes_in_runs_of_chunk_bytes():
    """Below ``STREAM_BYTES`` (estimated) a document is one body even with many samples; above it,
    it is streamed, in pieces of at least ``CHUNK_BYTES`` but the last, which join to the same bytes."""
    many = _body(3 * STREAM_POINTS, "float")
    assert encoding.estimate_bytes(many) < encoding.STREAM_BYTES
    assert json_response(many).body == orjson.dumps(many, option=JSON_OPTIONS)
    n, dof = 12_000, 20
    rng = np.random.default_rng(3)
    traj = Trajectory(np.linspace(0.0, 5.0, n), *(rng.normal(size=(n, dof)) for _ in range(3)))
    big = trajectory_body(traj, {"method": "test", "warnings": []}, "float", layout="points")
    assert encoding.estimate_bytes(big) > encoding.STREAM_BYTES
    response = json_response(big)
    assert not hasattr(response, "body")

    async def pieces() -> list[bytes]:
        return [chunk async for chunk in response.body_iterator]

    parts = asyncio.run(pieces())
    assert len(parts) > 1 and all(len(p) >= encoding.CHUNK_BYTES for p in parts[:-1])
    assert b"".join(parts) == orjson.dumps(big, option=JSON_OPTIONS)


# ------------------------------------------------- ?layout=columns and the size estimate (issue 19)

REQUESTS = {
    "/v1/trajectories/joint": {
        "profile": "quintic",
        "start": {"positions": [0.0, 0.2, -0.3]},
        "goal": {"positions": [1.0, -0.5, 0.4]},
        "duration": 1.7,
        "samples": 57,
    },
    "/v1/trajectories/spline": {
        "waypoints": [[0.0, 0.0], [1.0, 0.5], [0.0, 1.0]],
        "times": [0.0, 1.0, 2.5],
        "boundary": "natural",
        "samples": 33,
    },
    "/v1/trajectories/cartesian": {
        "robot": "ur5",
        "method": "sampled",
        "start": {"positions": [0.0, -1.0472, 1.5708, -2.0944, -1.5708, 0.0]},
        "goal": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]},
        "samples": 21,
    },
}


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(Settings(access_log=False))) as c:
        yield c


@pytest.mark.parametrize("url", list(REQUESTS))
@pytest.mark.parametrize("time_format", ["float", "ros"])
def test_columns_layout_carries_the_same_numbers(client, url, time_format):
    body = REQUESTS[url]
    points = client.post(f"{url}?time_format={time_format}", json=body)
    columns = client.post(f"{url}?time_format={time_format}&layout=columns", json=body)
    assert points.status_code == columns.status_code == 200, columns.text
    p, c = points.json(), columns.json()
    assert c["layout"] == "columns" and "points" not in c and "layout" not in p
    assert c["joint_names"] == p["joint_names"]
    for key in ("time_from_start", "positions", "velocities", "accelerations"):
        assert c[key] == [point[key] for point in p["points"]], key  # exact, every sample
    rows = np.asarray(c["positions"])
    assert rows.shape == (len(p["points"]), len(p["joint_names"]))
    diag_p = {k: v for k, v in p["diagnostics"].items() if k != "compute_time_ms"}
    diag_c = {k: v for k, v in c["diagnostics"].items() if k != "compute_time_ms"}
    assert diag_c == diag_p
    assert len(columns.content) < len(points.content)


def test_an_unknown_layout_is_422(client):
    r = client.post("/v1/trajectories/joint?layout=rows", json=REQUESTS["/v1/trajectories/joint"])
    assert r.status_code == 422 and r.json()["errors"][0]["loc"] == ["query", "layout"]


@pytest.mark.parametrize("n", [STREAM_POINTS + 1, 3 * STREAM_POINTS + 7])
@pytest.mark.parametrize("time_format", ["float", "ros"])
def test_streamed_columns_equal_one_shot(n, time_format, monkeypatch):
    monkeypatch.setattr(encoding, "STREAM_BYTES", 0)
    rng = np.random.default_rng(n)
    traj = Trajectory(np.linspace(0.0, 3.0, n), *(rng.normal(size=(n, 4)) for _ in range(3)))
    body = trajectory_body(traj, {"method": "test"}, time_format, layout="columns")
    response = json_response(body)
    assert not hasattr(response, "body")  # streamed
    streamed = asyncio.run(_collect(response))
    assert streamed == orjson.dumps(body, option=JSON_OPTIONS)
    assert np.array_equal(np.asarray(orjson.loads(streamed)["velocities"]), traj.velocities)


@pytest.mark.parametrize("dof", [1, 6, 64])
@pytest.mark.parametrize("layout", ["points", "columns"])
@pytest.mark.parametrize("time_format", ["float", "ros"])
def test_the_size_estimate_bounds_the_encoded_size(dof, layout, time_format):
    n = 2_000
    rng = np.random.default_rng(dof)
    traj = Trajectory(np.linspace(0.0, 1e3, n), *(rng.normal(size=(n, dof)) for _ in range(3)))
    body = trajectory_body(traj, {"method": "test"}, time_format, layout=layout)
    actual = len(orjson.dumps(body, option=JSON_OPTIONS))
    estimate = encoding.estimate_bytes(body)
    # an upper bound, and not a loose one: within 2x plus the per-sample framing
    assert actual <= estimate <= 2.0 * actual + n * encoding.BYTES_PER_SAMPLE, (actual, estimate)
