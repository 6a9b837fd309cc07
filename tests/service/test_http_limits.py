"""HTTP-level limits of the trajectory endpoints: 413 over 2 MiB with and without Content-Length,
NaN/Infinity and unknown fields are 422 naming the field, and no error echoes the value sent."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from tests.service.helpers import problem

JOINT, SPLINE = "/v1/trajectories/joint", "/v1/trajectories/spline"
LIMIT = 2 * 1024 * 1024
JOINT_BODY = {
    "profile": "cubic",
    "start": {"positions": [0.0, 0.0]},
    "goal": {"positions": [1.0, 0.5]},
    "duration": 2.0,
    "samples": 5,
}
SPLINE_BODY = {
    "waypoints": [[0.0, 0.0], [1.0, 0.5], [0.0, 1.0]],
    "times": [0.0, 1.0, 2.5],
    "boundary": "natural",
    "samples": 5,
}


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app()) as test_client:
        yield test_client


def padded(body: dict[str, Any], size: int) -> bytes:
    """``body`` as JSON, padded with trailing whitespace (still valid JSON) to ``size`` bytes."""
    raw = json.dumps(body).encode()
    return raw + b" " * (size - len(raw))


@pytest.mark.parametrize(("url", "body"), [(JOINT, JOINT_BODY), (SPLINE, SPLINE_BODY)])
def test_body_limit_with_content_length(client: TestClient, url: str, body: dict) -> None:
    headers = {"content-type": "application/json"}
    at_limit = client.post(url, content=padded(body, LIMIT), headers=headers)
    assert at_limit.status_code == 200, at_limit.text
    over = client.post(url, content=padded(body, LIMIT + 1), headers=headers)
    problem(over, 413, "too_large")


@pytest.mark.parametrize("url", [JOINT, SPLINE])
def test_body_limit_chunked_without_content_length(client: TestClient, url: str) -> None:
    def chunks() -> Iterator[bytes]:
        yield b'{"waypoints": [[0.0], [1.0]], "boundary": "natural", "x": "'
        for _ in range(5):
            yield b"a" * (512 * 1024)
        yield b'"}'

    response = client.post(url, content=chunks(), headers={"content-type": "application/json"})
    assert "content-length" not in response.request.headers
    assert response.request.headers["transfer-encoding"] == "chunked"
    problem(response, 413, "too_large")


def _raw_asgi_post(path: str, chunks: list[bytes]) -> tuple[int, bytes]:
    """Drive the ASGI app directly: a streamed body, no Content-Length header at all."""
    app = create_app()
    sent: list[dict[str, Any]] = []
    pending = iter(chunks)

    async def receive() -> dict[str, Any]:
        chunk = next(pending, None)
        if chunk is None:
            return {"type": "http.request", "body": b"", "more_body": False}
        return {"type": "http.request", "body": chunk, "more_body": True}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    scope = {
        "type": "http",
        "asgi": {"version": "3.0"},
        "http_version": "1.1",
        "method": "POST",
        "scheme": "http",
        "path": path,
        "raw_path": path.encode(),
        "query_string": b"",
        "root_path": "",
        "headers": [(b"content-type", b"application/json")],
        "client": ("127.0.0.1", 5000),
        "server": ("testserver", 80),
    }
    asyncio.run(app(scope, receive, send))
    start = next(m for m in sent if m["type"] == "http.response.start")
    return start["status"], b"".join(m.get("body", b"") for m in sent if "body" in m)


def test_streamed_body_at_the_asgi_level() -> None:
    raw = json.dumps(JOINT_BODY).encode()
    status, body = _raw_asgi_post(JOINT, [raw[:10], raw[10:]])
    assert status == 200, body
    status, body = _raw_asgi_post(JOINT, [b" " * (1024 * 1024)] * 2 + [b" "])
    assert status == 413 and json.loads(body)["code"] == "too_large"


NON_FINITE = ("NaN", "Infinity", "-Infinity", "1e999")


@pytest.mark.parametrize("token", NON_FINITE)
@pytest.mark.parametrize(
    ("url", "template", "loc"),
    [
        (JOINT, '{"profile": "cubic", "start": {"positions": [0, T]}, '
         '"goal": {"positions": [1, 1]}, "duration": 1}', ["body", "start", "positions", 1]),
        (JOINT, '{"profile": "cubic", "start": {"positions": [0]}, "goal": {"positions": [1]}, '
         '"duration": T}', ["body", "duration"]),
        (JOINT, '{"profile": "cubic", "start": {"positions": [0]}, "goal": {"positions": [1]}, '
         '"limits": {"velocity": [T]}}', ["body", "limits", "velocity", 0]),
        (SPLINE, '{"waypoints": [[0], [T]], "boundary": "natural", "times": [0, 1]}',
         ["body", "waypoints", 1, 0]),
        (SPLINE, '{"waypoints": [[0], [1]], "boundary": "natural", "times": [0, T]}',
         ["body", "times", 1]),
        (SPLINE, '{"waypoints": [[0], [1]], "boundary": "natural", "times": [0, 1], '
         '"sample_period": T}', ["body", "sample_period"]),
    ],
)  # fmt: skip
def test_non_finite_numbers_are_422_naming_the_field(
    client: TestClient, url: str, template: str, loc: list, token: str
) -> None:
    raw = template.replace("T", token)
    response = client.post(url, content=raw, headers={"content-type": "application/json"})
    body = problem(response, 422, "validation")
    assert body["errors"][0]["loc"] == loc
    assert token not in response.text and "nan" not in response.text.lower()


@pytest.mark.parametrize(
    ("url", "extra", "loc"),
    [
        (JOINT, {"jerk": 1}, ["body", "jerk"]),
        (JOINT, {"start": {"positions": [0.0, 0.0], "effort": [0.0, 0.0]}},
         ["body", "start", "effort"]),
        (JOINT, {"limits": {"velocity": [1.0, 1.0], "snap": [1.0, 1.0]}},
         ["body", "limits", "snap"]),  # limits.jerk is known since round 2 (jerk_limited)
        (SPLINE, {"tension": 0.5}, ["body", "tension"]),
    ],
)  # fmt: skip
def test_unknown_fields_are_422(client: TestClient, url: str, extra: dict, loc: list) -> None:
    base = JOINT_BODY if url == JOINT else SPLINE_BODY
    body = problem(client.post(url, json={**base, **extra}), 422, "validation")
    assert body["errors"][0]["loc"] == loc


def test_no_error_echoes_the_value_sent(client: TestClient) -> None:
    marker = 12345.6789  # outside |position| <= 1e4
    bad = [
        (JOINT, {**JOINT_BODY, "start": {"positions": [marker, 0.0]}}),
        (JOINT, {**JOINT_BODY, "duration": -marker}),
        (JOINT, {**JOINT_BODY, "profile": "profile-12345.6789"}),
        (SPLINE, {**SPLINE_BODY, "waypoints": [[0.0], [marker]]}),
        (SPLINE, {**SPLINE_BODY, "times": [0.0, marker, 1.0]}),  # not increasing: core says so
        (JOINT, {**JOINT_BODY, "samples": "12345.6789"}),
        (SPLINE, {**SPLINE_BODY, "boundary": "12345.6789"}),
    ]
    for url, body in bad:
        response = client.post(url, json=body)
        assert response.status_code == 422, (url, body, response.text)
        assert "12345" not in response.text, response.text


def test_malformed_json_and_wrong_shapes(client: TestClient) -> None:
    headers = {"content-type": "application/json"}
    problem(client.post(JOINT, content=b'{"profile": "cubic",', headers=headers), 422, "validation")
    problem(client.post(JOINT, content=b"[1, 2, 3]", headers=headers), 422, "validation")
    problem(client.post(SPLINE, json={**SPLINE_BODY, "waypoints": [0.0, 1.0]}), 422, "validation")
