"""Retries against a scripted stub server (``stub.py``): 503 ``overloaded`` and dropped connections
are tried again after a jittered exponential backoff or the server's ``Retry-After``; nothing else
is; the last failure is raised with its problem body. The client's sleep is recorded, not slept."""

from __future__ import annotations

import random
from typing import Any

import pytest
from trajectory_client import (
    NotReady,
    Overloaded,
    PlanningFailed,
    RetryPolicy,
    ServerError,
    TrajectoryClient,
    TransportError,
)

from tests.client.stub import Reply, problem, stub_server

FK = {
    "pose": {"position": [1.8, 0.0, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0]},
    "jacobian": [[0.0, 0.0], [1.8, 0.8], [0, 0], [0, 0], [0, 0], [1.0, 1.0]],
    "min_singular_value": 0.5,
    "manipulability": 0.4,
    "configuration": None,
    "frames": None,
}
OVERLOADED = Reply(503, problem(503, "overloaded", retry_after_s=1), {"Retry-After": "1"})


def client_of(url: str, **kwargs: Any) -> tuple[TrajectoryClient, list[float]]:
    client = TrajectoryClient(url, seed=7, **kwargs)
    waits: list[float] = []
    client._sleep = waits.append
    return client, waits


def test_503_overloaded_then_success_waits_the_retry_after() -> None:
    with stub_server([OVERLOADED, Reply(200, FK)]) as stub:
        client, waits = client_of(stub.url)
        result = client.fk("planar_2r", [0.0, 0.0])
    assert result.pose.position == [1.8, 0.0, 0.0]
    assert len(stub.requests) == 2 and stub.requests[0] == stub.requests[1]  # the same request
    policy = RetryPolicy()
    assert len(waits) == 1 and 1.0 <= waits[0] <= 1.0 + policy.backoff_s  # Retry-After + jitter


def test_overloaded_every_time_raises_after_the_last_attempt() -> None:
    policy = RetryPolicy(attempts=3)
    with stub_server([OVERLOADED] * 5) as stub:
        client, waits = client_of(stub.url, retry=policy)
        with pytest.raises(Overloaded) as caught:
            client.fk("planar_2r", [0.0, 0.0])
    assert len(stub.requests) == 3 and len(waits) == 2
    assert caught.value.retry_after == 1.0 and caught.value.body["retry_after_s"] == 1


def test_backoff_without_retry_after_doubles_with_jitter() -> None:
    bare = Reply(503, problem(503, "overloaded"))
    policy = RetryPolicy(attempts=4, backoff_s=0.1, max_backoff_s=0.25)
    with stub_server([bare] * 4) as stub:
        client, waits = client_of(stub.url, retry=policy)
        with pytest.raises(Overloaded):
            client.fk("planar_2r", [0.0, 0.0])
    steps = [0.1, 0.2, 0.25]  # doubled, capped
    assert len(stub.requests) == 4 and len(waits) == 3
    for wait, step in zip(waits, steps, strict=True):
        assert step / 2 <= wait <= step


def test_jitter_spreads_the_waits() -> None:
    policy = RetryPolicy()
    rng = random.Random(1)
    waits = {policy.delay(2, None, rng) for _ in range(50)}
    assert len(waits) == 50 and min(waits) >= 0.4 and max(waits) <= 0.8


def test_a_dropped_connection_is_tried_again() -> None:
    with stub_server([Reply(drop=True), Reply(200, FK)]) as stub:
        client, waits = client_of(stub.url)
        assert client.fk("planar_2r", [0.0, 0.0]).manipulability == 0.4
    assert len(stub.requests) == 2 and len(waits) == 1


def test_a_refused_connection_raises_transport_error_after_the_retries() -> None:
    with stub_server([]) as stub:
        url = stub.url  # the port is closed once the stub stops
    client, waits = client_of(url, retry=RetryPolicy(attempts=3))
    with pytest.raises(TransportError) as caught:
        client.health()
    assert len(waits) == 2 and caught.value.__cause__ is not None


def test_other_failures_are_not_retried() -> None:
    script = [
        Reply(422, problem(422, "unreachable", s=0.5)),
        Reply(503, problem(503, "not_ready"), {"Retry-After": "5"}),
    ]
    with stub_server(script) as stub:
        client, waits = client_of(stub.url)
        with pytest.raises(PlanningFailed) as caught:
            client.fk("planar_2r", [0.0, 0.0])
        assert caught.value.s == 0.5
        with pytest.raises(NotReady) as not_ready:
            client.ready()
    assert len(stub.requests) == 2 and waits == [] and not_ready.value.retry_after == 5.0


def test_a_retry_after_beyond_the_policy_is_raised_at_once() -> None:
    long = Reply(503, problem(503, "overloaded"), {"Retry-After": "120"})
    with stub_server([long, Reply(200, FK)]) as stub:
        client, waits = client_of(stub.url, retry=RetryPolicy(max_retry_after_s=30))
        with pytest.raises(Overloaded) as caught:
            client.fk("planar_2r", [0.0, 0.0])
    assert len(stub.requests) == 1 and waits == [] and caught.value.retry_after == 120.0


def test_a_timeout_is_a_transport_error_and_not_retried() -> None:
    with stub_server([Reply(200, FK, delay=1.0), Reply(200, FK)]) as stub:
        client, waits = client_of(stub.url, timeout=0.2)
        with pytest.raises(TransportError):
            client.fk("planar_2r", [0.0, 0.0])
    assert len(stub.requests) == 1 and waits == []


def test_a_body_that_is_not_problem_json_still_raises() -> None:
    with stub_server([Reply(502, "bad gateway")]) as stub:
        client, _ = client_of(stub.url)
        with pytest.raises(ServerError) as caught:
            client.health()
    assert caught.value.status == 502 and caught.value.code is None
    assert caught.value.detail == "bad gateway"
