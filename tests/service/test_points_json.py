"""The ROS-shaped points written straight from the arrays (``service.points_json``) are the bytes
orjson writes for the list of point dicts (``trajectory_points``), in one shot and streamed, for
both time formats, across magnitudes, signed zeros and any slice; and the joint route answers them."""

from __future__ import annotations

import asyncio

import numpy as np
import orjson
import pytest

from core.trajectory import Trajectory
from service import encoding
from service.encoding import (
    JSON_OPTIONS,
    STREAM_POINTS,
    estimate_bytes,
    json_response,
    trajectory_body,
    trajectory_points,
)
from service.points_json import PointsJSON, points_json


def _trajectory(seed: int, n: int, dof: int) -> Trajectory:
    rng = np.random.default_rng(seed)

    def values() -> np.ndarray:
        a = rng.normal(size=(n, dof)) * 10.0 ** rng.integers(-12, 12, size=(n, dof))
        a[rng.random((n, dof)) < 0.1] = 0.0
        a[rng.random((n, dof)) < 0.05] = -0.0
        a[rng.random((n, dof)) < 0.05] = 1.0
        return a

    times = np.cumsum(rng.uniform(1e-9, 10.0 ** rng.integers(-6, 3), n))
    times[0] = 0.0
    return Trajectory(times, values(), values(), values())


def _reference(traj: Trajectory, time_format: str, part: slice = slice(None)) -> bytes:
    return orjson.dumps(trajectory_points(traj, time_format)[part], option=JSON_OPTIONS)


@pytest.mark.parametrize("time_format", ["float", "ros"])
@pytest.mark.parametrize("seed", range(40))
def test_points_are_the_bytes_of_the_point_dicts(seed, time_format):
    rng = np.random.default_rng(1000 + seed)
    traj = _trajectory(seed, int(rng.integers(1, 400)), int(rng.integers(1, 9)))
    assert points_json(traj, time_format) == _reference(traj, time_format)
    n = traj.times.size
    start, stop = sorted(int(i) for i in rng.integers(0, n + 1, 2))
    assert points_json(traj, time_format, start, stop) == _reference(
        traj, time_format, slice(start, stop)
    )


def test_an_empty_slice_is_an_empty_array():
    assert points_json(_trajectory(0, 5, 2), "float", 3, 3) == b"[]"


async def _collect(response) -> bytes:
    parts = [chunk async for chunk in response.body_iterator]
    return b"".join(p if isinstance(p, bytes) else p.encode() for p in parts)


@pytest.mark.parametrize("n", [10, STREAM_POINTS, STREAM_POINTS + 1, 2 * STREAM_POINTS + 3])
@pytest.mark.parametrize("time_format", ["float", "ros"])
def test_encoded_document_equals_the_list_document(n, time_format, monkeypatch):
    monkeypatch.setattr(encoding, "STREAM_BYTES", 0)  # stream every document over STREAM_POINTS
    traj = _trajectory(n, n, 3)
    diag = {"method": "test", "warnings": []}
    plain = trajectory_body(traj, diag, time_format, "points", knots=[1, 2])
    fast = trajectory_body(traj, diag, time_format, "points", encoded=True, knots=[1, 2])
    assert isinstance(fast["points"], PointsJSON) and len(fast["points"]) == n
    assert estimate_bytes(fast) == estimate_bytes(plain)
    want = orjson.dumps(plain, option=JSON_OPTIONS)
    response = json_response(fast)
    got = asyncio.run(_collect(response)) if n > STREAM_POINTS else response.body
    assert got == want


def test_the_joint_route_answers_the_encoded_points(client):
    body = {
        "profile": "quintic",
        "start": {"positions": [0.0, -1.5]},
        "goal": {"positions": [1.0, 0.7]},
        "duration": 2.0,
        "samples": 7,
    }
    r = client.post("/v1/trajectories/joint", json=body)
    assert r.status_code == 200
    points = r.json()["points"]
    t = np.array([p["time_from_start"] for p in points])
    q = np.array([p["positions"] for p in points])
    s = t / 2.0
    want = (
        np.array([0.0, -1.5]) + np.array([1.0, 2.2]) * (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None]
    )
    assert np.allclose(q, want, rtol=0, atol=1e-12)
    assert q[0].tolist() == [0.0, -1.5] and q[-1].tolist() == [1.0, 0.7]
