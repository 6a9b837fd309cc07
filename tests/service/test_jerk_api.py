"""Jerk limits through the HTTP API: jerk_limited on /v1/trajectories/joint, limits.jerk in robot
descriptions, peak_jerk and exact peaks in every joint trajectory's diagnostics, and the bad inputs
(422 validation at the field, 422 infeasible with the reason)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
import ruckig
from fastapi.testclient import TestClient

from service.app import create_app
from tests.ros_rules import check_ros_trajectory
from tests.service.helpers import needs_registry, problem

URL = "/v1/trajectories/joint"
PANDA_JERK = 7500.0
"""rad/s^3, every joint: Franka Control Interface documentation, 'Limits for Panda'."""


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app()) as test_client:
        yield test_client


def jerk_move(dof: int = 2, **extra: Any) -> dict[str, Any]:
    body: dict[str, Any] = {
        "profile": "jerk_limited",
        "start": {"positions": [0.0] * dof},
        "goal": {"positions": [1.0 - 0.5 * i for i in range(dof)]},
        "limits": {"velocity": [1.0] * dof, "acceleration": [2.0] * dof, "jerk": [10.0] * dof},
    }
    body.update(extra)
    return body


def ruckig_duration(body: dict[str, Any]) -> float:
    """Ruckig's own time-optimal duration for a request without robot (independent of the route)."""
    dof = len(body["start"]["positions"])
    inp = ruckig.InputParameter(dof)
    zeros = [0.0] * dof
    inp.current_position = body["start"]["positions"]
    inp.current_velocity = body["start"].get("velocities", zeros)
    inp.current_acceleration = body["start"].get("accelerations", zeros)
    inp.target_position = body["goal"]["positions"]
    inp.target_velocity = body["goal"].get("velocities", zeros)
    inp.target_acceleration = body["goal"].get("accelerations", zeros)
    limits = body["limits"]
    inp.max_velocity, inp.max_acceleration = limits["velocity"], limits["acceleration"]
    inp.max_jerk = limits["jerk"]
    traj = ruckig.Trajectory(dof)
    ruckig.Ruckig(dof).calculate(inp, traj)
    return traj.duration


def test_jerk_limited_is_time_optimal_and_ends_exactly(client: TestClient) -> None:
    body = jerk_move(3)
    body["start"].update(velocities=[0.3, 0.0, -0.2], accelerations=[0.5, 0.0, 0.0])
    body["goal"].update(velocities=[0.0, 0.1, 0.0])
    response = client.post(URL, json=body)
    assert response.status_code == 200, response.text
    doc = response.json()
    parsed = check_ros_trajectory(doc, rest_to_rest=False)
    diag = doc["diagnostics"]
    assert diag["method"] == "jerk_limited"
    assert diag["duration"] == pytest.approx(ruckig_duration(body), rel=1e-12)
    for row, end in ((0, "start"), (-1, "goal")):
        np.testing.assert_allclose(parsed.positions[row], body[end]["positions"], atol=1e-9)
        v = body[end].get("velocities", [0.0] * 3)
        np.testing.assert_allclose(parsed.velocities[row], v, rtol=0, atol=1e-9)
    for key, limit in (("peak_velocity", 1.0), ("peak_acceleration", 2.0), ("peak_jerk", 10.0)):
        assert len(diag[key]) == 3 and max(diag[key]) <= limit * (1 + 1e-9), (key, diag[key])
    assert max(diag["peak_jerk"]) == pytest.approx(10.0)  # time-optimal: the jerk limit binds


def test_a_given_duration_is_exact_or_infeasible_naming_the_shortest(client: TestClient) -> None:
    shortest = ruckig_duration(jerk_move())
    doc = client.post(URL, json=jerk_move(duration=3.0, samples=31)).json()
    assert doc["diagnostics"]["duration"] == 3.0 and doc["points"][-1]["time_from_start"] == 3.0
    body = problem(client.post(URL, json=jerk_move(duration=0.5)), 422, "infeasible")
    assert f"{shortest:.6g} s" in body["detail"]


@pytest.mark.parametrize(
    ("jerk", "loc"),
    [
        ([0.0, 10.0], ["body", "limits", "jerk", 0]),
        ([10.0, -1.0], ["body", "limits", "jerk", 1]),
        ([10.0, 1e300], ["body", "limits", "jerk", 1]),
        ([10.0], ["body", "limits", "jerk"]),
        ([10.0, 10.0, 10.0], ["body", "limits", "jerk"]),
    ],
)
def test_bad_jerk_limits_are_validation_at_the_field(
    client: TestClient, jerk: list[float], loc: list[Any]
) -> None:
    body = jerk_move()
    body["limits"]["jerk"] = jerk
    answer = problem(client.post(URL, json=body), 422, "validation")
    assert any(e["loc"][: len(loc)] == loc for e in answer["errors"]), answer


def test_non_finite_jerk_is_validation(client: TestClient) -> None:
    raw = (
        '{"profile": "jerk_limited", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]}, '
        '"limits": {"velocity": [1.0], "acceleration": [1.0], "jerk": [Infinity]}}'
    )
    response = client.post(URL, content=raw, headers={"content-type": "application/json"})
    answer = problem(response, 422, "validation")
    assert answer["errors"][0]["loc"][:3] == ["body", "limits", "jerk"]


def test_missing_jerk_limit_is_validation_at_limits_jerk(client: TestClient) -> None:
    body = jerk_move()
    del body["limits"]["jerk"]
    answer = problem(client.post(URL, json=body), 422, "validation")
    assert answer["errors"][0]["loc"] == ["body", "limits", "jerk"]


@pytest.mark.parametrize(
    ("start", "goal", "words"),
    [
        ({"velocities": [1.5, 0.0]}, {}, "start.velocities of joint j1"),
        ({}, {"accelerations": [0.0, 3.0]}, "goal.accelerations of joint j2"),
        ({"velocities": [0.9, 0.0], "accelerations": [1.9, 0.0]}, {}, "brake"),
        ({}, {"velocities": [0.9, 0.0], "accelerations": [-1.9, 0.0]}, "joint j1"),
    ],
)
def test_unreachable_boundary_states_are_infeasible(
    client: TestClient, start: dict, goal: dict, words: str
) -> None:
    body = jerk_move()
    body["start"].update(start)
    body["goal"].update(goal)
    answer = problem(client.post(URL, json=body), 422, "infeasible")
    assert words in answer["detail"], answer["detail"]


def test_quintic_peaks_come_from_the_profile_not_the_samples(client: TestClient) -> None:
    body = {"profile": "quintic", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]}}
    doc = client.post(URL, json={**body, "duration": 1.0, "samples": 2}).json()
    diag = doc["diagnostics"]
    assert diag["peak_velocity"][0] == pytest.approx(1.875, rel=1e-12)
    assert diag["peak_acceleration"][0] == pytest.approx(10 / np.sqrt(3), rel=1e-12)
    assert diag["peak_jerk"][0] == pytest.approx(60.0, rel=1e-12)  # q''' = 60 at both ends


def test_every_joint_profile_and_the_spline_report_peak_jerk(client: TestClient) -> None:
    for profile, expected in (("linear", 0.0), ("cubic", 12.0), ("trapezoidal", 0.0)):
        body = {"profile": profile, "start": {"positions": [0.0]}, "goal": {"positions": [1.0]}}
        diag = client.post(URL, json={**body, "duration": 1.0}).json()["diagnostics"]
        assert diag["peak_jerk"] == [pytest.approx(expected)], profile
    spline = {"waypoints": [[0.0], [1.0], [0.0]], "times": [0.0, 1.0, 2.0], "boundary": "natural"}
    diag = client.post("/v1/trajectories/spline", json=spline).json()["diagnostics"]
    # natural spline through 0, 1, 0 at 0, 1, 2: q = 1.5 t - 0.5 t^3 on [0, 1]: |q'''| = 3.
    assert diag["peak_jerk"] == [pytest.approx(3.0)]


@needs_registry
def test_robot_descriptions_carry_jerk_limits(client: TestClient) -> None:
    panda = client.get("/v1/robots/panda").json()
    assert panda["limits"]["jerk"] == [PANDA_JERK] * 7
    assert "7500" in panda["limit_sources"]["jerk"]
    assert client.get("/v1/robots/ur5").json()["limits"]["jerk"] is None


@needs_registry
def test_panda_plans_within_its_published_limits(client: TestClient) -> None:
    panda = client.get("/v1/robots/panda").json()
    lo, hi = np.array(panda["limits"]["position"]).T
    goal = (lo + 0.8 * (hi - lo)).tolist()
    body = {"robot": "panda", "profile": "jerk_limited", "start": {"positions": panda["home"]},
            "goal": {"positions": goal}, "sample_period": 0.001}  # fmt: skip
    doc = client.post(URL, json=body).json()
    parsed = check_ros_trajectory(doc, rest_to_rest=True)
    diag = doc["diagnostics"]
    for key, name in (("peak_velocity", "velocity"), ("peak_acceleration", "acceleration")):
        assert np.all(np.array(diag[key]) <= np.array(panda["limits"][name]) * (1 + 1e-9)), key
    assert max(diag["peak_jerk"]) <= PANDA_JERK * (1 + 1e-9)
    assert max(diag["peak_jerk"]) == pytest.approx(PANDA_JERK)
    # Independent of the diagnostics: finite differences of the returned 1 kHz accelerations.
    jerk = np.diff(parsed.accelerations, axis=0) / np.diff(parsed.times)[:, None]
    assert np.abs(jerk).max() <= PANDA_JERK * (1 + 1e-6)


@needs_registry
def test_a_robot_without_published_jerk_needs_limits_jerk(client: TestClient) -> None:
    body = {"robot": "ur5", "profile": "jerk_limited", "start": {"positions": [0.0] * 6},
            "goal": {"positions": [0.5] * 6}}  # fmt: skip
    answer = problem(client.post(URL, json=body), 422, "validation")
    assert answer["errors"][0]["loc"] == ["body", "limits", "jerk"]
    body["limits"] = {"jerk": [50.0] * 6}
    assert client.post(URL, json=body).status_code == 200


def test_a_sub_millisecond_move_keeps_ruckigs_exact_duration(client: TestClient) -> None:
    """Issue 25 item 12: no silent stretch to 1 ms (Ruckig's own duration, however short)."""
    body = jerk_move(1, goal={"positions": [1e-4]})
    body["limits"] = {"velocity": [1.0], "acceleration": [1e4], "jerk": [1e8]}
    response = client.post(URL, json=body)
    assert response.status_code == 200, response.text
    doc = response.json()
    expected = ruckig_duration(body)
    assert 0.0 < expected < 1e-3
    assert doc["diagnostics"]["duration"] == pytest.approx(expected, rel=1e-12)
    assert doc["points"][-1]["time_from_start"] == pytest.approx(expected, rel=1e-12)
    assert not doc["diagnostics"]["warnings"]
