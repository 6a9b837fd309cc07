"""A ball on the line: every Cartesian method gives the same answer, 422 ``collision`` at the same
``s`` with the same links ("one answer per question"). ``bounded_deviation_nlp`` searched knot sets
that keep the clearance within the tolerance band, found none (the ball is wider than the band) and
answered 422 ``no_convergence``; it now returns Taylor's knots for the collision check to judge."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from core.cartesian.methods import METHODS as CARTESIAN_METHODS
from service.app import create_app
from tests.service.helpers import problem
from tests.service.test_rate_answers import BALL, OFFSET, UR5, lin

METHODS = list(CARTESIAN_METHODS)  # every method the service offers


@pytest.fixture(scope="module")
def answers() -> dict[str, dict]:
    client = TestClient(create_app())
    env = {"obstacles": [BALL]}
    return {
        m: problem(
            client.post(
                "/v1/trajectories/cartesian",
                json=lin(UR5, OFFSET, name="ur5", method=m, environment=env),
            ),
            422,
            "collision",
        )
        for m in METHODS
    }


@pytest.mark.parametrize("method", METHODS)
def test_every_method_reports_the_blocked_line_as_the_same_collision(answers, method) -> None:
    got, ref = answers[method], answers["sampled"]
    assert got["links"] == ref["links"] == ["wrist_3_link", "ball"]
    assert got["s"] == pytest.approx(ref["s"], abs=0.01)
    assert got["distance"] <= 1e-6
