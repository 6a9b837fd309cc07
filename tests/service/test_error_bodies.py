"""Issue 26.10: every error answer keeps docs/api.md's contract, on every error path.

A sweep of hostile and failing requests against every POST route of the live app (malformed,
mistyped, out-of-range, unknown-field and non-JSON bodies; planning failures of every kind; HTTP
errors): each answer is problem+json with a ``code`` of docs/api.md's table and that code's status,
``errors`` on every ``validation`` answer, every ``errors[].loc`` a field the route's request model
has, and no number written out in more than 20 digits. Before: a program's ``validation`` answer had
no ``errors``, a program's ``loc`` was ``["body", "limits"]`` (a program has no ``limits``),
``/v1/compare`` named ``["body", "duration"]`` for ``task.duration``, ``bad_request`` was not in the
table and a ``too_large`` detail held a 160-digit integer. ``test_fuzz.py`` applies the same check to
every answer schemathesis provokes.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient
from pydantic import BaseModel

from service import app as service_app
from service.app import create_app
from service.settings import Settings
from tests.service.helpers import documented_problem, documented_rows, needs_registry
from tests.service.test_docs import api_text, documented_codes
from tests.service.test_hostile_bodies import NUMERIC_PATHS, VALID, put

CODES = documented_codes(api_text())
UR5 = [0.0, -1.5, 1.5, -1.5, -1.5, 0.0]
UR5_TURN = [1.0, -1.5, 1.5, -1.5, -1.5, 0.0]
OUTSIDE = [7.0, -1.5, 1.5, -1.5, -1.5, 0.0]
"""A UR5 configuration whose first joint is past its 2 pi limit."""
FAR_POSE = {"position": [3.0, 0.0, 0.3], "orientation": [0.0, 0.0, 0.0, 1.0]}
TWO_LINK = (
    '<robot name="two"><link name="base_link"/><link name="l1"/><link name="tool0"/>'
    '<joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/>'
    '<axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
    '<joint name="j2" type="fixed"><parent link="l1"/><child link="tool0"/>'
    '<origin xyz="1 0 0"/></joint></robot>'
)


def _routes() -> dict[str, type[BaseModel]]:
    """Path template -> request model of every POST route of the computing routers."""
    out = {}
    for module in (*service_app.PLANNING_ROUTERS, *service_app.TRAJECTORY_ROUTERS):
        for route in module.router.routes:
            if isinstance(route, APIRoute) and "POST" in route.methods and route.body_field:
                out[route.path] = route.body_field.field_info.annotation
    return out


MODELS = _routes()


def model_of(url: str) -> type[BaseModel] | None:
    path = url.split("?")[0]
    for template, model in MODELS.items():
        if re.fullmatch(re.sub(r"\{[^}]+\}", "[^/]+", template), path):
            return model
    return None


def url_of(template: str) -> str:
    return template.replace("{name}", "ur5")


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(time_budget_s=2.0, access_log=False))) as test_client:
        yield test_client


def check(response: Any, url: str) -> dict[str, Any]:
    """The property: every 4xx/5xx answer is documented; a compare row's error too."""
    body = response.json()
    if response.status_code >= 400:
        documented_problem(
            response.status_code, response.headers["content-type"], body, CODES, model_of(url)
        )
    else:
        documented_rows(body, CODES, model_of(url))
    return body


JSON = {"content-type": "application/json"}
RAW_BODIES = (
    b"",
    b"{}",
    b"[]",
    b'"text"',
    b"null",
    b'{"unexpected": 1}',
    b'{"positions": ',
    b"\xff\xfe{}",
    b"[" * 10_000 + b"]" * 10_000,
    b'{"robot": 12, "positions": "x", "segments": {}, "task": [], "waypoints": [[]]}',
)


@pytest.mark.parametrize("template", sorted(MODELS))
def test_malformed_bodies_on_every_post_route(client: TestClient, template: str) -> None:
    url = url_of(template)
    for raw in RAW_BODIES:
        response = client.post(url, content=raw, headers=JSON)
        assert response.status_code == 422, (url, raw[:40], response.text)
        check(response, url)
    for content_type in ("text/plain", "application/x-www-form-urlencoded", ""):
        response = client.post(url, content=b"{}", headers={"content-type": content_type})
        assert check(response, url)["code"] == "unsupported_media_type"
    assert check(client.put(url, json={}), url)["code"] == "method_not_allowed"


def test_http_level_errors(client: TestClient) -> None:
    check(client.get("/v1/no/such/route"), "/v1/no/such/route")
    big = b'{"x": "' + b"a" * (2 * 1024 * 1024) + b'"}'
    url = "/v1/trajectories/joint"
    assert check(client.post(url, content=big, headers=JSON), url)["code"] == "too_large"


@pytest.mark.parametrize("url", sorted(VALID))
def test_mistyped_and_out_of_range_fields(client: TestClient, url: str) -> None:
    """Every numeric field of the hostile-bodies tests, mistyped and far out of range."""
    for path in NUMERIC_PATHS[url]:
        for value in ("x", [1.0], {"a": 1}, True, None, -1e300, 1e300, 10**160):
            check(client.post(url, json=put(VALID[url], path, value)), url)
        check(client.post(url, json={**VALID[url], "unexpected": 1}), url)


FAILING: list[tuple[str, dict[str, Any]]] = [
    (  # a program timed past the bound by its scales: was a 200 of 3.6e5 s
        "/v1/trajectories/program",
        {"robot": "ur5", "start": {"positions": UR5}, "samples": 3,
         "segments": [{"type": "ptp", "goal": {"positions": UR5_TURN},
                       "velocity_scale": 1e-9, "acceleration_scale": 1e-9}]},
    ),
    (  # a zero speed cap: a validation answer had no errors, then named ["body", "limits"]
        "/v1/trajectories/program",
        {"robot": "ur5", "start": {"positions": UR5},
         "segments": [{"type": "ptp", "goal": {"positions": UR5_TURN},
                       "velocity_scale": 1e-30, "acceleration_scale": 1e-30}]},
    ),
    (
        "/v1/trajectories/program",
        {"robot": "ur5", "start": {"positions": UR5},
         "segments": [{"type": "lin", "goal": {"pose": FAR_POSE}}]},
    ),
    (
        "/v1/trajectories/program",
        {"robot": "ur5", "start": {"positions": OUTSIDE},
         "segments": [{"type": "ptp", "goal": {"positions": UR5_TURN}}]},
    ),
    (
        "/v1/trajectories/program",
        {"robot": "ur5", "start": {"positions": UR5},
         "segments": [{"type": "ptp", "goal": {"positions": UR5_TURN}, "blend_radius": 0.5},
                      {"type": "ptp", "goal": {"positions": UR5}}]},
    ),
    (  # 1e155 points: the count was written out in 156 digits
        "/v1/trajectories/joint",
        {"profile": "cubic", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]},
         "duration": 1.0, "sample_period": 1e-155},
    ),
    (
        "/v1/trajectories/joint",
        {"profile": "quintic", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]},
         "limits": {"velocity": [1.0], "acceleration": [1.0]}, "duration": 0.1},
    ),
    (
        "/v1/trajectories/joint",
        {"profile": "jerk_limited", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]},
         "limits": {"velocity": [1.0], "acceleration": [1.0]}},
    ),
    (
        "/v1/trajectories/joint",
        {"robot": "ur5", "profile": "quintic", "start": {"positions": OUTSIDE},
         "goal": {"positions": UR5}},
    ),
    ("/v1/trajectories/joint", {"profile": "quintic", "start": {"positions": [0.0]},
                                "goal": {"positions": [1.0]}}),
    (
        "/v1/trajectories/spline",
        {"waypoints": [[0.0], [1.0]], "times": [0.0, 0.01], "boundary": "natural",
         "limits": {"velocity": [1.0], "acceleration": [1.0]}},
    ),
    (
        "/v1/trajectories/cartesian",
        {"robot": "ur5", "start": {"positions": UR5}, "goal": {"pose": FAR_POSE},
         "method": "sampled"},
    ),
    (
        "/v1/trajectories/cartesian",
        {"robot": "ur5", "start": {"positions": UR5}, "goal": {"positions": UR5_TURN},
         "method": "sampled", "duration": 0.01},
    ),
    (  # the task's fields are at task.* of a compare body (was ["body", "duration"])
        "/v1/compare",
        {"task": {"robot": "ur5", "start": {"positions": UR5}, "goal": {"positions": UR5_TURN},
                  "duration": 0.01}},
    ),
    (
        "/v1/compare",
        {"task": {"robot": "ur5", "start": {"positions": [0.0]},
                  "goal": {"positions": UR5_TURN}}},
    ),
    (
        "/v1/compare",
        {"task": {"robot": {"urdf": "<robot"}, "start": {"positions": [0.0]},
                  "goal": {"positions": [0.0]}}},
    ),
    ("/v1/robots/ur5/fk", {"positions": [0.0]}),
    ("/v1/robots/ur5/fk", {"positions": UR5, "frame": "no_such_frame"}),
    ("/v1/robots/no_such_robot/fk", {"positions": UR5}),
    ("/v1/robots/ur5/ik", {"pose": FAR_POSE}),
    ("/v1/robots/ur5/ik", {"pose": FAR_POSE, "all": True}),
    ("/v1/ik", {"robot": {"urdf": TWO_LINK}, "pose": FAR_POSE}),
    ("/v1/fk", {"robot": {"urdf": "<robot name='x'><link name='a'/></robot"}, "positions": [0.0]}),
    ("/v1/robots/describe", {"robot": {"urdf": TWO_LINK, "tip_frame": "nowhere"}}),
    ("/v1/robots/ur5/distance", {"positions": [0.0]}),
    ("/v1/robots/ur5/distance", {"positions": OUTSIDE}),
    ("/v1/distance", {"robot": "ur5", "positions": UR5,
                      "environment": {"obstacles": [{"name": "shoulder_link",
                                                     "shape": {"type": "sphere", "radius": 0.1}}]}}),
]  # fmt: skip


@needs_registry
@pytest.mark.parametrize(
    ("url", "body"), FAILING, ids=[f"{u}-{i}" for i, (u, _) in enumerate(FAILING)]
)
def test_planning_failures(client: TestClient, url: str, body: dict[str, Any]) -> None:
    response = client.post(url, json=body)
    assert response.status_code != 200 or url == "/v1/compare", response.text
    check(response, url)


def test_the_sweep_checks_the_route_models() -> None:
    """The sweep knows every POST route's model, so a wrong ``loc`` cannot pass unseen."""
    assert model_of("/v1/trajectories/program").__name__ == "ProgramRequest"
    assert model_of("/v1/robots/ur5/fk") is not None and model_of("/v1/compare") is not None
    with pytest.raises(AssertionError, match="not a field"):
        bad = {"type": "x/validation", "status": 422, "code": "validation", "detail": "d",
               "errors": [{"loc": ["body", "speed"], "msg": "m"}]}  # fmt: skip
        documented_problem(
            422, "application/problem+json", bad, CODES, model_of("/v1/trajectories/program")
        )
    with pytest.raises(AssertionError, match="no errors"):
        bare = {"type": "x/validation", "status": 422, "code": "validation", "detail": "d"}
        documented_problem(422, "application/problem+json", bare, CODES)
    with pytest.raises(AssertionError):
        long = {"type": "x/too_large", "status": 422, "code": "too_large", "detail": "1" * 160}
        documented_problem(422, "application/problem+json", long, CODES)
    assert json.dumps(CODES)  # the table parsed


@pytest.mark.parametrize("tag", ["blob", 10**20, [10**20], {"a": 1}])
def test_an_unknown_union_tag_is_named_not_echoed(client: TestClient, tag: Any) -> None:
    """A shape whose ``type`` is no known tag: the message names the field and the tags it may
    take; pydantic's own quoted the client's tag (a 21-digit integer in the slow fuzz run)."""
    url = "/v1/robots/ur5/distance"
    shape = {"name": "a", "shape": {"type": tag},
             "pose": {"position": [0, 0, 0], "orientation": [0, 0, 0, 1]}}  # fmt: skip
    body = {"positions": UR5, "environment": {"obstacles": [shape]}}
    err = check(client.post(url, json=body), url)
    assert err["code"] == "validation"
    assert err["errors"][0]["loc"] == ["body", "environment", "obstacles", 0, "shape"]
    assert "'box', 'sphere'" in err["errors"][0]["msg"] and str(tag) not in err["detail"]
