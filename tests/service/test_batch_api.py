"""POST /v1/batch: every item answered as its endpoint answers the same body, in order, one failure
never failing the others, one collision model per distinct robot and environment, under the
batch's time budget and size limits, streamed as NDJSON on request.

The reference of each item's answer is the endpoint itself, asked the same body in a request of
its own (timings, the ``*_ms`` keys, aside)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import orjson
import pytest
from fastapi.testclient import TestClient

from bench.batch import ENVIRONMENT, UR5_HOME, joint_moves, lines
from robots import collision
from service.app import create_app
from service.batch.endpoints import ENDPOINTS
from service.encoding import RESPONSE_BUDGET
from service.schemas.batch import MAX_ITEMS
from service.settings import Settings
from tests.service.helpers import problem

JOINT = {
    "profile": "quintic",
    "start": {"positions": [0.0, 0.0]},
    "goal": {"positions": [1.0, 0.5]},
    "duration": 2.0,
    "samples": 5,
}
PLANAR_TASK = {
    "robot": "planar_2r",
    "start": {"positions": [0.3, 1.2]},
    "goal": {"pose": {"position": [1.79, 0.0, 0.0], "orientation": [0, 0, 0, 1]}},
    "duration": 1.0,
}
"""The planar arm's tool out to 1.79 m, inside its 1.8 m reach (a /v1/compare task)."""
PLANAR_LINE = {**PLANAR_TASK, "method": "sampled"}
UNREACHABLE_LINE = {
    **PLANAR_LINE,
    "goal": {"pose": {"position": [0.05, 0.0, 0.0], "orientation": [0, 0, 0, 1]}},
}
"""Into the hole of the planar arm's annulus (0.2 m <= r <= 1.8 m): 422 unreachable at some s."""
MIXED: list[tuple[str, dict[str, Any]]] = [
    ("trajectories/joint", JOINT),
    ("trajectories/joint", {**JOINT, "goal": {"positions": [1.0, math.nan]}}),
    ("trajectories/spline", {"waypoints": [[0.0], [1.0], [0.5]], "times": [0.0, 1.5, 3.0], "boundary": "natural"}),
    ("trajectories/cartesian", lines(1)[0]),
    ("trajectories/cartesian", UNREACHABLE_LINE),
    (
        "trajectories/program",
        {
            "robot": "ur5",
            "start": {"positions": UR5_HOME},
            "segments": [{"type": "ptp", "goal": {"positions": joint_moves(1)[0]["goal"]["positions"]}}],
        },
    ),
    ("compare", {"task": PLANAR_TASK, "methods": ["sampled", "bounded_deviation"]}),
    ("fk", {"robot": "ur5", "positions": UR5_HOME}),
    ("fk", {"robot": "no_such_robot", "positions": [0.0]}),
    ("ik", {"robot": "planar_2r", "pose": {"position": [1.0, 0.8, 0.0], "orientation": [0, 0, 0, 1]}, "all": True}),
    ("distance", {"robot": "ur5", "positions": UR5_HOME, "environment": ENVIRONMENT}),
]  # fmt: skip


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings())) as test_client:
        yield test_client


def post_batch(client: TestClient, items: list[tuple[str, dict[str, Any]]], **extra: Any) -> Any:
    body = {"items": [{"endpoint": e, "body": b} for e, b in items], **extra}
    # the stdlib's JSON writes NaN, as a client might: the item's endpoint must refuse it
    return client.post(
        "/v1/batch",
        content=orjson.dumps(body) if not _has_nan(body) else _stdlib_json(body),
        headers={"content-type": "application/json"},
    )


def _has_nan(value: Any) -> bool:
    if isinstance(value, float):
        return math.isnan(value)
    if isinstance(value, dict):
        return any(_has_nan(v) for v in value.values())
    if isinstance(value, list):
        return any(_has_nan(v) for v in value)
    return False


def _stdlib_json(value: Any) -> bytes:
    import json

    return json.dumps(value).encode()


def without_timings(value: Any) -> Any:
    """``value`` without the keys that measure time (``compute_time_ms`` and any ``*_ms``)."""
    if isinstance(value, dict):
        return {k: without_timings(v) for k, v in value.items() if not k.endswith("_ms")}
    if isinstance(value, list):
        return [without_timings(v) for v in value]
    return value


def test_every_item_is_answered_as_its_endpoint_answers_it(client: TestClient) -> None:
    response = post_batch(client, MIXED)
    assert response.status_code == 200, response.text
    answer = response.json()
    assert [r["index"] for r in answer["results"]] == list(range(len(MIXED)))
    statuses = []
    for (endpoint, body), result in zip(MIXED, answer["results"], strict=True):
        alone = client.post(
            ENDPOINTS[endpoint].path,
            content=_stdlib_json(body),
            headers={"content-type": "application/json"},
        )
        assert result["endpoint"] == endpoint
        assert result["status"] == alone.status_code, (endpoint, result["body"])
        assert without_timings(result["body"]) == without_timings(alone.json()), endpoint
        statuses.append(result["status"])
    # the mix holds successes and each family of failure, none failing the others
    assert statuses.count(200) == 8 and sorted(set(statuses)) == [200, 404, 422]
    summary = answer["summary"]
    assert (summary["items"], summary["succeeded"], summary["failed"]) == (11, 8, 3)
    assert summary["not_started"] == 0 and summary["budget_s"] == 60.0


def test_a_failed_item_carries_its_endpoints_problem(client: TestClient) -> None:
    results = post_batch(client, MIXED[:2] + MIXED[4:5] + MIXED[8:9]).json()["results"]
    nan, unreachable, unknown = results[1]["body"], results[2]["body"], results[3]["body"]
    assert nan["code"] == "validation"
    assert nan["errors"][0]["loc"] == ["body", "goal", "positions", 1]  # inside the item
    assert unreachable["code"] == "unreachable" and 0 < unreachable["s"] < 1
    assert unknown["code"] == "unknown_robot" and "ur5" in unknown["available"]


class CountingChecker(collision.CollisionChecker):
    built = 0

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        CountingChecker.built += 1
        super().__init__(*args, **kwargs)


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> type[CountingChecker]:
    from service.convert import environment

    monkeypatch.setattr(environment, "CollisionChecker", CountingChecker)
    CountingChecker.built = 0
    return CountingChecker


def test_items_with_the_same_robot_and_environment_share_one_collision_model(
    client: TestClient, counted: type[CountingChecker]
) -> None:
    moves = joint_moves(6)
    other = {**ENVIRONMENT, "clearance": 0.02}  # another environment: its own model
    items = [("trajectories/joint", m) for m in moves[:3]]
    items += [("trajectories/cartesian", b) for b in lines(2)]
    items += [("trajectories/joint", {**m, "environment": other}) for m in moves[3:]]
    answer = post_batch(client, items).json()
    assert [r["status"] for r in answer["results"]] == [200] * 8
    assert counted.built == 2
    shared = answer["summary"]["shared"]["collision_model"]
    assert shared["built"] == 2 and shared["reused"] >= 6


def test_a_request_of_its_own_builds_its_collision_model_once(
    client: TestClient, counted: type[CountingChecker]
) -> None:
    response = client.post("/v1/trajectories/cartesian", json=lines(1)[0])
    assert response.status_code == 200, response.text
    assert counted.built == 1  # the rate rows and the continuous check share it


def test_defaults_fill_the_fields_an_item_takes(client: TestClient) -> None:
    move, line = joint_moves(1)[0], lines(1)[0]
    bare_move = {k: v for k, v in move.items() if k not in ("robot", "environment")}
    bare_line = {k: v for k, v in line.items() if k not in ("robot", "environment")}
    fk = {"positions": UR5_HOME}  # takes robot, not environment
    items = [("trajectories/joint", bare_move), ("trajectories/cartesian", bare_line), ("fk", fk)]
    answer = post_batch(client, items, defaults={"robot": "ur5", "environment": ENVIRONMENT})
    results = answer.json()["results"]
    assert [r["status"] for r in results] == [200, 200, 200]
    full = post_batch(client, [("trajectories/joint", move), ("trajectories/cartesian", line)])
    for with_defaults, sent_in_full in zip(results, full.json()["results"], strict=False):
        assert without_timings(with_defaults["body"]) == without_timings(sent_in_full["body"])
    # an item's own value wins over the default
    own = post_batch(client, [("fk", {**fk, "robot": "panda"})], defaults={"robot": "ur5"})
    assert own.json()["results"][0]["status"] == 422  # panda has 7 joints: its own robot was used


def test_a_default_no_item_takes_is_422(client: TestClient) -> None:
    response = post_batch(client, [("fk", {"robot": "ur5", "positions": UR5_HOME})],
                          defaults={"environment": ENVIRONMENT})  # fmt: skip
    body = problem(response, 422, "validation")
    assert body["errors"][0]["loc"] == ["body", "defaults", "environment"]


@pytest.mark.parametrize(
    ("body", "loc"),
    [
        ({"items": []}, ["body", "items"]),
        ({"items": [{"endpoint": "fk", "body": {}}] * (MAX_ITEMS + 1)}, ["body", "items"]),
        ({"items": [{"endpoint": "batch", "body": {}}]}, ["body", "items", 0, "endpoint"]),
        ({"items": [{"endpoint": "fk", "body": [1, 2]}]}, ["body", "items", 0, "body"]),
        ({"items": [{"endpoint": "fk"}]}, ["body", "items", 0, "body"]),
        ({"items": [], "extra": 1}, ["body", "extra"]),
    ],
)
def test_a_malformed_envelope_fails_the_batch(client: TestClient, body: Any, loc: list) -> None:
    body_doc = problem(client.post("/v1/batch", json=body), 422, "validation")
    assert loc in [e["loc"] for e in body_doc["errors"]]


def test_the_stream_answers_one_line_per_item_then_the_summary(client: TestClient) -> None:
    items = MIXED[:3] + MIXED[7:9]
    whole = post_batch(client, items).json()
    body = {"items": [{"endpoint": e, "body": b} for e, b in items]}
    response = client.post(
        "/v1/batch?stream=ndjson",
        content=_stdlib_json(body),
        headers={"content-type": "application/json"},
    )
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("application/x-ndjson")
    lines_ = [orjson.loads(line) for line in response.text.splitlines()]
    assert [x["index"] for x in lines_[:-1]] == list(range(len(items)))
    assert without_timings(lines_[:-1]) == without_timings(whole["results"])
    assert set(lines_[-1]) == {"summary"} and lines_[-1]["summary"]["items"] == len(items)


def test_layout_and_time_format_apply_to_every_item(client: TestClient) -> None:
    items = [("trajectories/joint", JOINT), ("fk", {"robot": "ur5", "positions": UR5_HOME})]
    body = {"items": [{"endpoint": e, "body": b} for e, b in items]}
    answer = client.post("/v1/batch?layout=columns&time_format=ros", json=body).json()
    plan = answer["results"][0]["body"]
    alone = client.post("/v1/trajectories/joint?layout=columns&time_format=ros", json=JOINT).json()
    assert plan["layout"] == "columns" and plan["time_from_start"][1] == {
        "sec": 0,
        "nanosec": 500_000_000,
    }
    assert without_timings(plan) == without_timings(alone)
    assert answer["results"][1]["status"] == 200


SLOW_LINE = {
    "robot": "ur5",
    "method": "resolved_rate",
    "start": {"positions": UR5_HOME},
    "goal": {"positions": joint_moves(1)[0]["goal"]["positions"]},
    "control_period": 1e-4,
    "duration": 40.0,
}
"""400,000 control ticks: runs until a deadline stops it."""


def test_the_batch_budget_stops_the_running_item_and_leaves_the_rest_unstarted() -> None:
    budget = 0.5
    with TestClient(create_app(Settings(batch_budget_s=budget))) as client:
        items = [
            ("fk", {"robot": "ur5", "positions": UR5_HOME}),
            ("trajectories/cartesian", SLOW_LINE),
        ]
        items += [("trajectories/joint", JOINT)] * 3
        answer = post_batch(client, items).json()
    results, summary = answer["results"], answer["summary"]
    assert results[0]["status"] == 200
    stopped = results[1]["body"]
    assert stopped["code"] == "time_budget_exceeded" and stopped["budget_s"] <= budget
    for result in results[2:]:
        assert result["status"] == 422 and result["body"]["code"] == "time_budget_exceeded"
        assert (
            result["body"]["budget_s"] == budget
            and "before this item started" in result["body"]["detail"]
        )
    assert (summary["not_started"], summary["succeeded"], summary["failed"]) == (3, 1, 4)


def test_the_items_together_stay_within_the_answer_size_limit() -> None:
    limit = 6000
    with TestClient(create_app(Settings(max_response_bytes=limit))) as client:
        items = [("trajectories/joint", {**JOINT, "samples": 20})] * 4
        items += [("fk", {"robot": "planar_2r", "positions": [0.0, 1.0]})]
        results = post_batch(client, items).json()["results"]
    admitted = [r for r in results if r["status"] == 200]
    refused = [r["body"] for r in results if r["status"] != 200]
    assert sum(len(orjson.dumps(r["body"])) for r in admitted) <= limit
    assert refused and all(b["code"] == "too_large" and b["limit_bytes"] == limit for b in refused)
    assert results[-1]["status"] == 200  # a smaller item after a refused one still fits


def test_an_item_over_the_workers_memory_budget_is_503_and_every_byte_is_returned() -> None:
    with TestClient(create_app(Settings(response_budget_bytes=1024))) as client:
        before = RESPONSE_BUDGET.in_flight
        items = [("trajectories/joint", {**JOINT, "samples": 50})] * 2
        results = post_batch(client, items).json()["results"]
        assert results[0]["status"] == 200
        assert results[1]["status"] == 503 and results[1]["body"]["code"] == "overloaded"
        assert results[1]["body"]["retry_after_s"] >= 1
        assert RESPONSE_BUDGET.in_flight == before


def test_an_item_that_hits_a_defect_is_500_and_the_others_are_answered(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    from service.routes import robots

    def broken(*_: Any) -> Any:
        raise RuntimeError("a defect")

    monkeypatch.setattr(robots, "_fk", broken)
    results = post_batch(client, [("fk", {"robot": "ur5", "positions": UR5_HOME}), ("trajectories/joint", JOINT)]).json()["results"]  # fmt: skip
    assert results[0]["status"] == 500 and results[0]["body"]["code"] == "internal_error"
    assert results[1]["status"] == 200


def test_every_endpoint_of_the_table_is_a_post_route(client: TestClient) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    for endpoint, (path, model) in ENDPOINTS.items():
        assert "post" in paths[path], endpoint
        schema = paths[path]["post"]["requestBody"]["content"]["application/json"]["schema"]
        assert schema["$ref"].endswith(model.__name__), endpoint
