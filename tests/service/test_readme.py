"""Every ``curl`` of the README works: each is sent to the app in-process and answers the documented
status (200 unless a ``# 4xx {...}`` answer follows it) and, where the README shows an answer, that
answer (by the rules of ``tests/doc_curls.py``: abridged with ``...``, numbers to the digits shown).
A newcomer copies these first; a drifted one would be their first failure."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from tests.doc_curls import CurlExample, curl_examples, mismatches, parse_answer

README = Path(__file__).resolve().parents[2] / "README.md"
EXAMPLES = curl_examples(README.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def test_the_readme_has_a_tour() -> None:
    """The first request and one request per capability: joint (and jerk-limited), spline, line,
    arc, program, obstacles, IK with all, compare."""
    bodies = b"\n".join(e.body or b"" for e in EXAMPLES)
    urls = {e.url.split("?")[0] for e in EXAMPLES}
    assert {
        "/v1/trajectories/joint",
        "/v1/trajectories/spline",
        "/v1/trajectories/cartesian",
        "/v1/trajectories/program",
        "/v1/compare",
        "/v1/robots/ur5/ik",
    } <= urls
    for needle in (b'"circ"', b'"obstacles"', b'"all": true', b'"jerk_limited"'):
        assert needle in bodies, needle
    first = EXAMPLES[0]
    assert first.url == "/v1/trajectories/joint" and first.answer, (
        "the first request and its answer"
    )


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e.name)
def test_readme_curl(client: TestClient, example: CurlExample) -> None:
    response = client.request(
        example.method,
        example.url,
        content=example.body,
        headers={"content-type": "application/json"},
    )
    assert response.status_code == example.status, response.text[:500]
    if example.code is not None:
        assert response.json()["code"] == example.code
    if example.answer is not None:
        wrong = mismatches(parse_answer(example.answer), response.json())
        assert not wrong, "\n".join(wrong)
