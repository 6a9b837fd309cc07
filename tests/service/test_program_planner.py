"""Program PTP segments with ``"planner": "collision_free"`` (API.md "Collision-free motions",
its "Programs" bullet).

Every answer is re-checked independently of the planner: coal's distances (through pinocchio, every
pair) at the returned points and between them (``coal_sweep_margin`` of the collision-free route's
tests), and the numpy engine's continuous check of the returned motion.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from bench import mbm
from tests.service.helpers import problem
from tests.service.test_collision_free_api import checker, coal_sweep_margin

URL = "/v1/trajectories/program"
PROBLEMS = {p.name: p for p in mbm.problems(2)}


def program(name: str, planner: bool, **extra: Any) -> dict[str, Any]:
    """The MBM problem as a one-PTP program (spherized Panda, its environment)."""
    req = mbm.request(PROBLEMS[name])
    ptp: dict[str, Any] = {"type": "ptp", "goal": req["goal"]}
    if planner:
        ptp["planner"] = "collision_free"
    return {"robot": req["robot"], "environment": req["environment"], "start": req["start"],
            "segments": [ptp], **extra}  # fmt: skip


def assert_clear(body: dict[str, Any], doc: dict[str, Any]) -> None:
    check = checker(body["robot"], body["environment"])
    qs = np.array([p["positions"] for p in doc["points"]])
    times = np.array([p["time_from_start"] for p in doc["points"]])
    assert coal_sweep_margin(check, qs) >= 0.0
    assert check.check_path(times, qs).contact is None


@pytest.mark.parametrize("name", ["box/1", "bookshelf_small/1"])
def test_a_ptp_that_would_hit_an_obstacle_is_planned_around_it(client, name: str) -> None:
    problem(client.post(URL, json=program(name, planner=False)), 422, "collision")
    body = program(name, planner=True)
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert_clear(body, doc)
    q = np.array([p["positions"] for p in doc["points"]])
    np.testing.assert_array_equal(q[0], body["start"]["positions"])
    np.testing.assert_allclose(q[-1], body["segments"][0]["goal"]["positions"], atol=1e-12)
    planner = doc["segments"][0]["diagnostics"]["planner"]
    assert planner["name"] == "rrt_connect" and planner["seed"] == 0
    straight = np.linalg.norm(q[-1] - q[0])
    assert planner["path_length"] > straight  # a detour
    assert doc["segments"][0]["diagnostics"]["timing"] == "time_optimal"


def test_planned_ptps_blend_with_their_neighbours_and_stay_clear(client) -> None:
    body = program("box/1", planner=True)
    there = body["segments"][0]
    there["blend_radius"] = 0.05
    back = {"type": "ptp", "goal": {"positions": body["start"]["positions"]},
            "planner": "collision_free"}  # fmt: skip
    body["segments"] = [there, back]
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert_clear(body, doc)
    first = doc["segments"][0]
    assert first["blend_out"] is not None  # no stop at the first goal
    t = np.array([p["time_from_start"] for p in doc["points"]])
    v = np.array([p["velocities"] for p in doc["points"]])
    inside = (t > first["blend_out"]["start_time"]) & (t < first["blend_out"]["end_time"])
    assert np.linalg.norm(v[inside], axis=1).min() > 1e-3


def test_the_same_program_and_seed_give_the_same_answer(client) -> None:
    body = program("box/1", planner=True, seed=5)

    def strip(doc: dict[str, Any]) -> dict[str, Any]:
        doc = dict(doc)
        doc["diagnostics"] = {k: v for k, v in doc["diagnostics"].items() if k != "compute_time_ms"}
        for s in doc["segments"]:
            planner = s["diagnostics"].get("planner")
            if planner:
                s["diagnostics"]["planner"] = {k: v for k, v in planner.items()
                                               if not k.endswith("_ms")}  # fmt: skip
        return doc

    first = strip(client.post(URL, json=body).json())
    assert strip(client.post(URL, json=body).json()) == first
    assert first["segments"][0]["diagnostics"]["planner"]["seed"] == 5


def test_without_an_environment_the_ptp_is_straight(client) -> None:
    body = program("box/1", planner=True)
    body.pop("environment")
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    doc = r.json()
    assert "planner" not in doc["segments"][0]["diagnostics"]
    q = np.array([p["positions"] for p in doc["points"]])
    d = q[-1] - q[0]
    u = (q - q[0]) @ d / (d @ d)
    assert np.abs(q - (q[0] + u[:, None] * d)).max() < 1e-9


def test_planner_options_are_validated(client) -> None:
    body = program("box/1", planner=True)
    body["segments"][0]["planner"] = "rrt_star"
    err = problem(client.post(URL, json=body), 422, "validation")
    assert err["errors"][0]["loc"][-1] == "planner"
    body = program("box/1", planner=True)
    body["segments"][0]["profile"] = "trapezoidal"
    err = problem(client.post(URL, json=body), 422, "validation")
    assert err["errors"][0]["loc"][-3:] == ["segments", 0, "profile"]
    lin = {"type": "lin", "goal": body["segments"][0]["goal"], "planner": "collision_free"}
    err = problem(client.post(URL, json={**body, "segments": [lin]}), 422, "validation")
    assert err["errors"][0]["loc"][-1] == "planner"
