"""The collision stage over HTTP (issue 26.6, issue 28): a start (or a goal given as joints) in
collision is refused before any planning, on every route; a contact with a link at the base names
``environment.allowed_collisions``. Spies on the planners show that nothing was planned."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.cartesian.methods import METHODS
from core.joint.profiles import PROFILES
from core.program import timed as program_timed
from robots import registry
from service.app import create_app
from service.schemas.common import Pose
from tests.service.helpers import problem

UR5 = registry.get("ur5")
HOME = UR5.home.tolist()
RAISED = {"name": "table", "shape": {"type": "halfspace", "normal": [0, 0, 1], "offset": 0.02}}
"""A table 2 cm above the UR5's base plane: the shoulder link (9 mm above it) is inside."""


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def _goal_pose() -> dict:
    T = UR5.fk(UR5.home)
    T[:3, 3] += [0.05, 0.0, 0.0]
    return Pose.from_matrix(T).model_dump()


def _never(*args, **kwargs):
    raise AssertionError("planned although the start is in collision")


BODIES = {
    "cartesian": {"method": "bounded_deviation_nlp", "goal": {"pose": _goal_pose()}},
    "joint": {"profile": "quintic", "goal": {"positions": (np.array(HOME) + 0.1).tolist()}},
    "spline": {"waypoints": [HOME, (np.array(HOME) + 0.1).tolist()], "boundary": "clamped"},
    "program": {"segments": [{"type": "lin", "goal": {"pose": _goal_pose()}}]},
}


@pytest.mark.parametrize("route", list(BODIES))
def test_a_start_in_collision_is_refused_before_planning(client, monkeypatch, route):
    """Was: found only after planning (an NLP line took ~8 s to be refused). The planner is never
    called; the answer is 422 ``collision`` at the start, with the pair and the hint."""
    monkeypatch.setitem(METHODS, "bounded_deviation_nlp", _never)
    monkeypatch.setattr(PROFILES["quintic"], "timed", _never)
    monkeypatch.setattr(program_timed, "build", _never)
    body = {"robot": "ur5", "environment": {"obstacles": [RAISED]}, **BODIES[route]}
    if route != "spline":
        body["start"] = {"positions": HOME}
    err = problem(client.post(f"/v1/trajectories/{route}", json=body), 422, "collision")
    assert err["at"] == "start" and err["links"] == ["shoulder_link", "table"]
    assert err["distance"] < 0
    assert "allowed_collisions" in err["detail"]


def test_the_hint_is_right_listing_the_pair_lets_the_plan_through(client):
    body = {"robot": "ur5", "start": {"positions": HOME}, **BODIES["joint"]}
    body["environment"] = {
        "obstacles": [RAISED],
        "allowed_collisions": [["shoulder_link", "table"]],
    }
    resp = client.post("/v1/trajectories/joint", json=body)
    assert resp.status_code == 200, resp.text
    assert resp.json()["diagnostics"]["min_clearance"] > 0  # the other pairs are clear


def test_a_goal_given_as_joints_in_collision_is_refused_before_planning(client, monkeypatch):
    goal = np.array(HOME)
    goal[1] += 0.9  # shoulder lift down: the tool goes below a table at the base plane
    table = {"name": "table", "shape": {"type": "halfspace", "normal": [0, 0, 1], "offset": 0.0}}
    monkeypatch.setattr(PROFILES["quintic"], "timed", _never)
    body = {"robot": "ur5", "start": {"positions": HOME}, "goal": {"positions": goal.tolist()},
            "profile": "quintic", "environment": {"obstacles": [table]}}  # fmt: skip
    err = problem(client.post("/v1/trajectories/joint", json=body), 422, "collision")
    assert err["at"] == "goal" and err["links"][1] == "table"
    assert "allowed_collisions" not in err["detail"]  # a wrist link: the arm can move it away
