"""The streamed encoding of large trajectory documents is byte-identical to the one-shot one."""

from __future__ import annotations

import asyncio

import numpy as np
import orjson
import pytest

from core.trajectory import Trajectory
from service.encoding import JSON_OPTIONS, STREAM_POINTS, json_response, trajectory_body


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
def test_streamed_body_equals_one_shot(n, time_format):
    body = _body(n, time_format)
    response = json_response(body)
    assert not hasattr(response, "body")  # streamed
    streamed = asyncio.run(_collect(response))
    assert streamed == orjson.dumps(body, option=JSON_OPTIONS)
    assert len(orjson.loads(streamed)["points"]) == n


def test_small_body_is_one_shot():
    body = _body(10, "float")
    assert json_response(body).body == orjson.dumps(body, option=JSON_OPTIONS)
