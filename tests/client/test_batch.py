"""``TrajectoryClient.batch``: results yielded in order as the service streams them, each the value
the endpoint's own method returns (or the exception it raises); a stream cut mid-way resubmits
only the items not answered yet."""

from __future__ import annotations

import json

import numpy as np
import pytest
from trajectory_client import (
    BatchItem,
    FKResult,
    InvalidRequest,
    NotFound,
    PlanningFailed,
    Trajectory,
    TrajectoryClient,
    TransportError,
)

from bench.batch import ENVIRONMENT, UR5_HOME, joint_moves
from tests.client.stub import Reply, stub_server
from tests.client.test_client import COLLISION_FREE, JOINT, PLANAR_TASK, RETIME


def test_a_batch_streams_typed_results_in_order(service_url: str) -> None:
    moves = joint_moves(4)
    far = {**PLANAR_TASK, "method": "sampled",
           "goal": {"pose": {"position": [0.05, 0.0, 0.0], "orientation": [0, 0, 0, 1]}}}  # fmt: skip
    items = [("trajectories/joint", m) for m in moves]
    items += [("trajectories/cartesian", far), ("fk", {"robot": "nope", "positions": [0.0]})]
    items += [BatchItem("fk", {"robot": "ur5", "positions": UR5_HOME})]
    with TrajectoryClient(service_url) as client:
        stream = client.batch(items, as_numpy=True)
        results = list(stream)
        alone = client.joint(moves[0], as_numpy=True)
        fk = client.fk("ur5", UR5_HOME)
    assert [r.index for r in results] == list(range(7))
    assert [r.ok for r in results] == [True] * 4 + [False, False, True]
    first = results[0].value
    assert isinstance(first, Trajectory) and np.array_equal(first.positions, alone.positions)
    assert isinstance(results[4].error, PlanningFailed) and 0 < results[4].error.s < 1
    assert isinstance(results[5].error, NotFound)
    with pytest.raises(NotFound):
        results[5].result()
    assert isinstance(results[6].value, FKResult) and results[6].value.pose == fk.pose
    assert stream.summary is not None and stream.summary["items"] == 7
    assert stream.summary["shared"]["collision_model"] == {"built": 1, "reused": 3}


def test_retime_and_collision_free_in_a_batch(service_url: str) -> None:
    items = [("trajectories/retime", RETIME), ("trajectories/collision_free", COLLISION_FREE)]
    bad = {**COLLISION_FREE, "max_planning_time": 1e9}
    with TrajectoryClient(service_url) as client:
        results = list(client.batch([*items, ("trajectories/collision_free", bad)]))
        alone = [client.retime(RETIME), client.collision_free(COLLISION_FREE)]
    assert [r.ok for r in results] == [True, True, False]
    for result, single in zip(results, alone, strict=False):
        assert isinstance(result.value, Trajectory)
        assert result.value.positions == single.positions
        assert result.value.time_from_start == single.time_from_start
    assert results[1].value.raw["waypoints"] == alone[1].raw["waypoints"]
    assert isinstance(results[2].error, InvalidRequest)
    assert results[2].error.body["errors"][0]["loc"] == ["body", "max_planning_time"]


def test_defaults_are_sent_once(service_url: str) -> None:
    bare = [
        {k: v for k, v in m.items() if k not in ("robot", "environment")} for m in joint_moves(3)
    ]
    with TrajectoryClient(service_url) as client:
        results = list(
            client.batch(
                [("trajectories/joint", b) for b in bare],
                defaults={"robot": "ur5", "environment": ENVIRONMENT},
            )
        )
        alone = client.joint(joint_moves(3)[2])
    assert all(r.ok for r in results)
    assert results[2].value.positions == alone.positions
    assert "min_clearance" in results[2].value.diagnostics


def _line(index: int, body: object) -> bytes:
    doc = {"index": index, "endpoint": "trajectories/joint", "status": 200, "body": body}
    return json.dumps(doc).encode() + b"\n"


PLAN = {
    "joint_names": ["j1"],
    "layout": "columns",
    "time_from_start": [0.0, 1.0],
    "positions": [[0.0], [1.0]],
    "velocities": [[0.0], [0.0]],
    "accelerations": [[0.0], [0.0]],
    "diagnostics": {"duration": 1.0, "warnings": []},
}


def test_a_cut_stream_resubmits_only_the_unanswered_items() -> None:
    items = [("trajectories/joint", {**JOINT, "duration": 1.0 + k}) for k in range(4)]
    summary = json.dumps({"summary": {"items": 2}}).encode() + b"\n"
    script = [
        Reply(chunks=[_line(0, PLAN), _line(1, PLAN)], cut=True),  # items 0 and 1, then cut
        Reply(chunks=[_line(0, PLAN), _line(1, PLAN), summary]),  # the resubmitted 2 and 3
    ]
    with stub_server(script) as stub:
        client = TrajectoryClient(stub.url, seed=1)
        waits: list[float] = []
        client._sleep = waits.append
        results = list(client.batch(items))
    assert [r.index for r in results] == [0, 1, 2, 3] and all(r.ok for r in results)
    first, second = stub.requests[0][2], stub.requests[1][2]
    assert [i["body"]["duration"] for i in first["items"]] == [1.0, 2.0, 3.0, 4.0]
    assert [i["body"]["duration"] for i in second["items"]] == [3.0, 4.0]
    assert "stream=ndjson" in stub.requests[0][1] and len(waits) == 1


def test_a_stream_cut_every_time_raises_after_the_retries() -> None:
    items = [("trajectories/joint", JOINT)] * 2
    script = [Reply(chunks=[_line(0, PLAN)], cut=True)] + [Reply(chunks=[], cut=True)] * 3
    with stub_server(script) as stub:
        client = TrajectoryClient(stub.url)
        client._sleep = lambda _: None
        stream = client.batch(items)
        assert next(stream).index == 0
        with pytest.raises(TransportError):
            next(stream)
    assert len(stub.requests) == 4
