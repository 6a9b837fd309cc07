"""Hand-written hostile bodies against every POST endpoint: what schemathesis cannot generate.

NaN, Infinity, -Infinity and 1e400 (which Python's json turns into inf) in every kind of numeric
field, deeply nested JSON, arrays over their max_length, wrong types, unknown fields, empty arrays,
strings where numbers go, invalid UTF-8, wrong or missing content types, and bodies of 2 MiB + 1
byte with and without Content-Length. Every answer must be a 4xx ``application/problem+json`` with a
``code``, its ``status`` equal to the HTTP status, within a second, and must not echo the offending
value: each hostile value carries ``MARKER``, and the answer must not contain it.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.settings import Settings

MARKER = "zq7MARKERx91"
"""Put in every hostile value; no answer may contain it."""
LIMIT = 2 * 1024 * 1024
UR5 = [0.0, -1.0472, 1.5708, -2.0944, -1.5708, 0.0]
POSE = {"position": [-0.4, -0.11, 0.3], "orientation": [0.7071068, 0.7071068, 0.0, 0.0]}
CARTESIAN_TASK = {
    "robot": "ur5",
    "start": {"positions": UR5},
    "goal": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]},
    "samples": 5,
}
VALID: dict[str, dict[str, Any]] = {
    "/v1/trajectories/joint": {
        "profile": "quintic",
        "start": {"positions": [0.0, 0.0]},
        "goal": {"positions": [1.0, 0.5]},
        "duration": 2.0,
        "samples": 5,
    },
    "/v1/trajectories/spline": {
        "waypoints": [[0.0, 0.0], [1.0, 0.5], [0.0, 1.0]],
        "times": [0.0, 1.0, 2.5],
        "boundary": "natural",
        "samples": 5,
    },
    "/v1/trajectories/cartesian": {**CARTESIAN_TASK, "method": "sampled"},
    "/v1/compare": {"task": CARTESIAN_TASK, "methods": ["sampled"]},
    "/v1/robots/ur5/fk": {"positions": UR5},
    "/v1/robots/ur5/ik": {"pose": POSE, "seed": UR5},
}
URLS = list(VALID)
NUMERIC_PATHS: dict[str, list[tuple[Any, ...]]] = {
    "/v1/trajectories/joint": [
        ("start", "positions", 1),
        ("goal", "positions", 0),
        ("duration",),
        ("samples",),
    ],
    "/v1/trajectories/spline": [("waypoints", 1, 0), ("times", 1)],
    "/v1/trajectories/cartesian": [
        ("start", "positions", 2),
        ("goal", "positions", 5),
        ("samples",),
    ],
    "/v1/compare": [("task", "start", "positions", 0), ("task", "samples",)],
    "/v1/robots/ur5/fk": [("positions", 3)],
    "/v1/robots/ur5/ik": [("pose", "position", 0), ("pose", "orientation", 3), ("seed", 1)],
}  # fmt: skip
"""Where a number goes in each valid body (a path of keys and indices)."""
EXTRA_NUMERIC: dict[str, dict[str, Any]] = {
    "/v1/trajectories/joint": {"limits": {"velocity": [1.0, 1.0], "acceleration": [1.0, 1.0]}},
    "/v1/trajectories/cartesian": {"tolerance": {"position": 1e-3, "orientation": 1e-2}},
}
"""Optional numeric fields added to the valid body to be poisoned too."""
EXTRA_PATHS: dict[str, list[tuple[Any, ...]]] = {
    "/v1/trajectories/joint": [("limits", "velocity", 1), ("limits", "acceleration", 0)],
    "/v1/trajectories/cartesian": [("tolerance", "position"), ("tolerance", "orientation")],
}
NON_FINITE = ("NaN", "Infinity", "-Infinity", "1e400", "-1e400")
JSON = {"content-type": "application/json"}


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(time_budget_s=2.0, access_log=False))) as test_client:
        yield test_client


def hostile(
    response: Any, statuses: tuple[int, ...] = (422,), started: float | None = None
) -> dict:
    """Assert a 4xx problem+json answer (status in ``statuses``) that does not echo MARKER."""
    assert response.status_code in statuses, response.text[:2000]
    assert response.headers["content-type"].startswith("application/problem+json"), response.text
    body = response.json()
    assert body["status"] == response.status_code and isinstance(body["code"], str), body
    assert body["type"].endswith("/" + body["code"]) and body["title"] and body["detail"]
    assert MARKER not in response.text, response.text[:2000]
    if started is not None:
        assert time.perf_counter() - started < 1.0, "a hostile body took over a second"
    return body


def put(body: Any, path: tuple[Any, ...], value: Any) -> Any:
    """A deep copy of ``body`` with ``value`` at ``path``."""
    body = json.loads(json.dumps(body))
    node = body
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return body


def raw_with(body: Any, path: tuple[Any, ...], token: str) -> bytes:
    """``body`` as JSON text with the bare token (``NaN``, ``1e400``) at ``path``."""
    return json.dumps(put(body, path, "__TOKEN__")).replace('"__TOKEN__"', token).encode()


def post(client: TestClient, url: str, content: bytes, headers: dict | None = None) -> Any:
    return client.post(url, content=content, headers=JSON if headers is None else headers)


def test_the_valid_bodies_are_valid(client: TestClient) -> None:
    for url, body in VALID.items():
        response = client.post(url, json=body)
        assert response.status_code == 200, (url, response.text)


@pytest.mark.parametrize("token", NON_FINITE)
@pytest.mark.parametrize("url", URLS)
def test_non_finite_numbers_everywhere(client: TestClient, url: str, token: str) -> None:
    base = {**VALID[url], **EXTRA_NUMERIC.get(url, {})}
    for path in NUMERIC_PATHS[url] + EXTRA_PATHS.get(url, []):
        started = time.perf_counter()
        response = post(client, url, raw_with(base, path, token))
        body = hostile(response, started=started)
        assert body["code"] == "validation", body
        assert body["errors"][0]["loc"][: len(path) + 1] == ["body", *path], (path, body)
        text = response.text.lower()
        assert "nan" not in text and "infinity" not in text and "1e400" not in text, text


@pytest.mark.parametrize("url", URLS)
def test_wrong_types_strings_and_empty_arrays(client: TestClient, url: str) -> None:
    base = VALID[url]
    for path in NUMERIC_PATHS[url]:
        for value in (MARKER, [MARKER], {"x": MARKER}, True, False, "1.5", "12e" + MARKER):
            started = time.perf_counter()
            hostile(client.post(url, json=put(base, path, value)), started=started)
        if isinstance(path[-1], int):  # an element of an array: null, the array empty, a string
            hostile(client.post(url, json=put(base, path, None)))
            hostile(client.post(url, json=put(base, path[:-1], [])))
            hostile(client.post(url, json=put(base, path[:-1], MARKER)))
    hostile(client.post(url, json=[MARKER]))
    hostile(client.post(url, json=MARKER))
    hostile(client.post(url, json=None))
    hostile(client.post(url, json={}))


@pytest.mark.parametrize("url", URLS)
def test_unknown_fields_name_the_field_not_the_value(client: TestClient, url: str) -> None:
    body = hostile(client.post(url, json={**VALID[url], "unexpected": MARKER}))
    assert body["errors"][0]["loc"] == ["body", "unexpected"]
    nested = (
        {**VALID[url], "limits": {"velocity": [1.0, 1.0]}} if "spline" in url else {**VALID[url]}
    )
    key = next((k for k, v in nested.items() if isinstance(v, dict)), None)
    if key is None:  # fk: no nested object
        return
    nested[key] = {**nested[key], "effort": [MARKER]}
    body = hostile(client.post(url, json=nested))
    assert body["errors"][0]["loc"][:3] == ["body", key, "effort"], body


@pytest.mark.parametrize("url", URLS)
def test_arrays_over_their_max_length(client: TestClient, url: str) -> None:
    base = VALID[url]
    path = NUMERIC_PATHS[url][0]
    array = path[:-1]  # the array holding the first numeric field
    for length in (65, 10_001, 200_000):
        started = time.perf_counter()
        body = hostile(client.post(url, json=put(base, array, [0.5] * length)), started=started)
        assert body["code"] == "validation"
    if url == "/v1/trajectories/spline":
        waypoints = [[0.0, 0.0]] * 10_001
        hostile(client.post(url, json={**base, "waypoints": waypoints, "times": None}))


@pytest.mark.parametrize("url", URLS)
def test_deeply_nested_json(client: TestClient, url: str) -> None:
    for depth in (1_000, 100_000, 1_000_000):
        raw = b'{"x": ' + b"[" * depth + b"]" * depth + b"}"
        started = time.perf_counter()
        body = hostile(post(client, url, raw), started=started)
        assert body["code"] == "validation"
    raw = b"[" * 500_000  # unterminated, 0.5 MB
    hostile(post(client, url, raw))


@pytest.mark.parametrize("url", URLS)
def test_invalid_utf8_and_malformed_json(client: TestClient, url: str) -> None:
    for raw in (
        b'{"profile": "\xff\xfe\xfd"}',
        b"\xc3\x28" * 1000,
        json.dumps(VALID[url]).encode()[:-1] + b"\xff}",
        b"\x00" * 64,
        b'{"a": 1,}',
        b"",
        b"{" + f'"{MARKER}"'.encode(),
    ):
        body = hostile(post(client, url, raw))
        assert body["code"] == "validation"


@pytest.mark.parametrize("url", URLS)
def test_wrong_or_missing_content_type(client: TestClient, url: str) -> None:
    """A body that is not declared JSON is 415 ``unsupported_media_type`` naming the expected type
    (was 422 ``validation`` about the body, or parsed as JSON without the header); a valid body
    under ``application/json`` with parameters or under ``application/*+json`` is accepted."""
    valid = json.dumps(VALID[url]).encode()
    form = f"positions={MARKER}".encode()
    multipart = b"--zz\r\n\r\n" + MARKER.encode() + b"\r\n--zz--\r\n"
    for content, content_type in (
        (valid, "text/plain"),
        (valid, "application/x-www-form-urlencoded"),
        (valid, "application/xml"),
        (valid, "application/jsonx"),
        (valid, "application/+json"),
        (valid, "text/json"),
        (valid, ""),
        (form, "application/x-www-form-urlencoded"),
        (multipart, "multipart/form-data; boundary=zz"),
    ):
        body = hostile(post(client, url, content, {"content-type": content_type}), (415,))
        assert body["code"] == "unsupported_media_type" and "application/json" in body["detail"]
    missing = client.post(url, content=valid)
    assert "content-type" not in missing.request.headers
    assert hostile(missing, (415,))["code"] == "unsupported_media_type"
    assert missing.headers["accept-post"] == "application/json"
    for content_type in (
        "application/json; charset=utf-8",
        "Application/JSON",
        "application/problem+json",
    ):
        assert post(client, url, valid, {"content-type": content_type}).status_code == 200


@pytest.mark.parametrize("url", URLS)
def test_over_2_mib_is_413_with_and_without_content_length(client: TestClient, url: str) -> None:
    raw = json.dumps(VALID[url]).encode()
    at_limit = raw + b" " * (LIMIT - len(raw))
    assert client.post(url, content=at_limit, headers=JSON).status_code == 200
    hostile(client.post(url, content=at_limit + b" ", headers=JSON), (413,))

    def chunks() -> Iterator[bytes]:
        yield raw[:-1] + b', "x": "' + MARKER.encode()
        for _ in range(5):
            yield b"a" * (512 * 1024)
        yield b'"}'

    response = client.post(url, content=chunks(), headers=JSON)
    assert "content-length" not in response.request.headers
    body = hostile(response, (413,))
    assert body["code"] == "too_large"
    lying = {**JSON, "content-length": str(LIMIT + 1)}  # declared over the limit: refused unread
    hostile(client.post(url, content=at_limit + b" ", headers=lying), (413,))


def test_hostile_path_and_query_parameters(client: TestClient) -> None:
    for name in (MARKER, "a" * 65, "ur5%00", "..%2F..%2Fetc", "ür5"):
        response = client.post(f"/v1/robots/{name}/fk", json={"positions": UR5})
        hostile(response, (404, 422))
        hostile(client.get(f"/v1/robots/{name}"), (404, 422))
    for value in (MARKER, "", "ROS", "float" * 1000):
        url = f"/v1/trajectories/joint?time_format={value}"
        hostile(client.post(url, json=VALID["/v1/trajectories/joint"]))


def test_inline_urdf_errors_do_not_echo_the_offending_text(client: TestClient) -> None:
    good_joint = (
        '<joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
    )
    urdfs = [
        f"<robot name='r'><link name='l0'/><link name='l1'/>{good_joint.replace('revolute', MARKER)}</robot>",
        f"<robot name='r'><link name='l0'/><link name='l1'/>{good_joint.replace('-1', MARKER)}</robot>",
        f"<robot name='r'><link name='l0'/><link name='l1'/>{good_joint.replace('0 0 1', MARKER)}</robot>",
        f"<robot name='r'><link name='l0'/>{MARKER}<link name='l1'/>",
        f"<!DOCTYPE r [<!ENTITY e '{MARKER}'>]><robot name='&e;'/>",
        f"<{MARKER}/>",
    ]
    body = {**VALID["/v1/trajectories/cartesian"], "start": {"positions": [0.1]}}
    body["goal"] = {"positions": [0.2]}
    for urdf in urdfs:
        robot = {"urdf": urdf, "tip_frame": "l1", "base_frame": "l0"}
        response = client.post("/v1/trajectories/cartesian", json={**body, "robot": robot})
        problem = hostile(response)
        assert problem["code"] in ("invalid_urdf", "validation"), problem


def test_the_service_still_answers_after_all_that(client: TestClient) -> None:
    for url, body in VALID.items():
        response = client.post(url, json=body)
        assert response.status_code == 200, (url, response.text)
        numbers = json.loads(response.text, parse_constant=lambda c: math.nan)
        assert numbers  # parse_constant would turn NaN/Infinity into nan: none may appear
        assert "NaN" not in response.text and "Infinity" not in response.text


def test_undeclared_methods_are_405_with_allow(client: TestClient) -> None:
    for method, url, allowed in (
        ("TRACE", "/health", "GET"),
        ("DELETE", "/v1/trajectories/joint", "POST"),
        ("PUT", "/v1/robots/ur5/fk", "POST"),
    ):
        response = client.request(method, url)
        body = hostile(response, (405,))
        assert body["code"] == "method_not_allowed"
        assert allowed in response.headers["allow"], response.headers


def test_openapi_documents_errors_as_problem_json(client: TestClient) -> None:
    spec = client.get("/openapi.json").json()
    for path, operations in spec["paths"].items():
        for method, operation in operations.items():
            for status, response in operation["responses"].items():
                content = response.get("content", {})
                if status.startswith(("4", "5")) and content:
                    assert set(content) == {"application/problem+json"}, (method, path, status)


@pytest.mark.parametrize(
    "url", ["/v1/trajectories/joint", "/v1/trajectories/spline", "/v1/trajectories/cartesian"]
)
def test_subnormal_sample_period_is_too_large_not_a_crash(client: TestClient, url: str) -> None:
    """5e-324 s makes duration / period overflow to inf: 422 too_large (was a 500)."""
    body = {k: v for k, v in VALID[url].items() if k != "samples"}
    for period in (5e-324, 1e-300, 1e-12):
        problem = hostile(client.post(url, json={**body, "sample_period": period}))
        assert problem["code"] == "too_large", problem


# ----------------------------------------------------------------- issue 19, items 1 and 7


def one_joint_urdf(velocity: str = "1", effort: str = "1", name: str = "shoulder") -> str:
    return (
        "<robot name='r'><link name='l0'/><link name='l1'/>"
        f'<joint name="{name}" type="revolute"><parent link="l0"/><child link="l1"/>'
        f'<axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="{velocity}" effort="{effort}"/>'
        "</joint></robot>"
    )


def spline_with(urdf: str) -> dict[str, Any]:
    """The issue's repro: one joint, waypoints [[0], [0.5]], clamped, 5 samples, limits from the URDF."""
    return {
        "robot": {"urdf": urdf, "tip_frame": "l1", "base_frame": "l0"},
        "waypoints": [[0.0], [0.5]],
        "boundary": "clamped",
        "samples": 5,
    }


@pytest.mark.parametrize(
    ("velocity", "effort"),
    [("1e-300", "1"), ("1e-100", "1"), ("9.9e-7", "1"), ("5e-324", "1"), ("1", "1e-300")],
)
def test_tiny_urdf_rate_limits_are_invalid_urdf_naming_the_joint(
    client: TestClient, velocity: str, effort: str
) -> None:
    urdf = one_joint_urdf(velocity, effort)
    started = time.perf_counter()
    response = client.post("/v1/trajectories/spline", json=spline_with(urdf))
    problem = hostile(response, started=started)
    assert problem["code"] == "invalid_urdf", problem
    assert "'shoulder'" in problem["detail"] and "1e-06" in problem["detail"], problem
    assert problem["errors"][0]["loc"] == ["body", "robot", "urdf"], problem


def test_urdf_rate_limits_at_the_request_bound_or_absent_still_plan(client: TestClient) -> None:
    for velocity in ("1e-5", "0", "2.5"):
        response = client.post(
            "/v1/trajectories/spline", json=spline_with(one_joint_urdf(velocity))
        )
        assert response.status_code == 200, (velocity, response.text)
        points = response.json()["points"]
        assert points[-1]["positions"] == [0.5] and points[0]["positions"] == [0.0]
    # 1e-5 rad/s is honoured, not replaced by the default: 0.5 rad takes at least 0.5e5 s
    slow = client.post("/v1/trajectories/spline", json=spline_with(one_joint_urdf("1e-5")))
    assert slow.json()["diagnostics"]["duration"] >= 0.5 / 1e-5


def test_unknown_routes_and_traversal_paths_are_problem_json_not_found(
    client: TestClient,
) -> None:
    for url in ("/nope", "/v1/robots/..%2F..%2Fetc/fk", "/v1/robots/ur5/fk/extra", "/v1/"):
        response = client.post(url, json={})
        body = hostile(response, (404,))
        assert body["code"] == "not_found", (url, body)
        assert body["detail"] == "no endpoint serves this path", body
    # a registered route with an unknown robot keeps its own, more precise code
    body = hostile(client.post("/v1/robots/etc/fk", json={"positions": [0.0]}), (404,))
    assert body["code"] == "unknown_robot"


def test_an_arithmetic_overflow_is_422_not_500() -> None:
    app = create_app(Settings(access_log=False))

    @app.get("/overflow")
    def overflow() -> None:
        raise OverflowError("math range error")

    with TestClient(app) as c:
        body = hostile(c.get("/overflow"))
        assert body["code"] == "infeasible" and "overflow" in body["detail"]
