"""POST /v1/trajectories/cartesian with ``bounded_deviation`` and ``bounded_deviation_nlp``.

Through the HTTP layer: the ROS rules, the top-level ``knots`` and ``knot_count``, the measured
deviations in the diagnostics, the bound checked again here from the returned points with the
robot's own FK (joints interpolated linearly at 12 points between consecutive points), fewer knots
for the NLP on the issue's UR5 move, ``?time_format=ros`` knots, and the errors as problem+json.
"""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation, Slerp

from robots import registry
from service.app import create_app
from service.settings import Settings
from tests.ros_rules import check_ros_trajectory
from tests.service.conftest import pose_body

URL = "/v1/trajectories/cartesian"
METHODS = ("bounded_deviation", "bounded_deviation_nlp")
TOLERANCE = {"position": 1e-3, "orientation": 1e-2}


def ur5_request(method: str, **extra) -> dict:
    """The UR5 from home: the tool 0.3 m away along (2, 1.5, -1.5), turned 30 deg about (1, 1, 0)."""
    robot = registry.get("ur5")
    T0 = robot.fk(robot.home)
    T = T0.copy()
    direction = np.array([0.2, 0.15, -0.15])
    T[:3, 3] += 0.3 * direction / np.linalg.norm(direction)
    turn = Rotation.from_rotvec(np.radians(30) * np.array([1.0, 1.0, 0.0]) / np.sqrt(2))
    T[:3, :3] = turn.as_matrix() @ T0[:3, :3]
    body = {
        "robot": "ur5",
        "start": {"positions": robot.home.tolist()},
        "goal": {"pose": pose_body(T)},
        "method": method,
        "tolerance": TOLERANCE,
    }
    body.update(extra)
    return body


def deviation_between_points(request: dict, positions: np.ndarray, checks: int = 12):
    """Largest position [m] and orientation [rad] deviation from the request's line, joints
    interpolated linearly between consecutive points (closest point by position, slerp there)."""
    robot = registry.get(request["robot"])
    T0 = robot.fk(np.array(request["start"]["positions"]))
    goal = request["goal"]
    if "positions" in goal:
        T1 = robot.fk(np.array(goal["positions"]))
    else:
        T1 = np.eye(4)
        T1[:3, 3] = goal["pose"]["position"]
        T1[:3, :3] = Rotation.from_quat(goal["pose"]["orientation"]).as_matrix()
    frac = np.arange(checks + 1)[:, None] / (checks + 1)
    q = (positions[:-1, None, :] * (1 - frac) + positions[1:, None, :] * frac).reshape(
        -1, robot.dof
    )
    q = np.vstack([q, positions[-1]])
    T = robot.fk_many(q)
    xy = robot.task_space == "position_xy"
    rows = slice(0, 2) if xy else slice(0, 3)
    p0, d = T0[rows, 3], T1[rows, 3] - T0[rows, 3]
    s = np.clip((T[:, rows, 3] - p0) @ d / (d @ d), 0.0, 1.0)
    position = np.linalg.norm(T[:, rows, 3] - (p0 + s[:, None] * d), axis=1).max()
    if xy:
        return float(position), 0.0
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]])))
    orientation = (slerp(s).inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude().max()
    return float(position), float(orientation)


def check_body(request: dict, body: dict) -> dict:
    parsed = check_ros_trajectory(body, rest_to_rest=True)
    diag = body["diagnostics"]
    robot = registry.get(request["robot"])
    assert diag["method"] == request["method"] and diag["fraction"] == 1.0
    knots = body["knots"]
    assert diag["knot_count"] == len(knots) >= 2
    assert knots[0]["s"] == 0.0 and knots[-1]["s"] == 1.0
    assert knots[0]["time_from_start"] == 0.0
    assert knots[-1]["time_from_start"] == pytest.approx(parsed.times[-1])
    assert all(len(k["positions"]) == robot.dof for k in knots)
    assert knots[0]["positions"] == request["start"]["positions"]
    assert knots[-1]["positions"] == body["points"][-1]["positions"]
    assert diag["max_position_deviation"] <= TOLERANCE["position"]
    assert diag["max_orientation_deviation"] <= TOLERANCE["orientation"]
    pos, ori = deviation_between_points(request, parsed.positions)
    assert pos <= TOLERANCE["position"] and ori <= TOLERANCE["orientation"]
    lo, hi = robot.position_limits.T
    assert np.all((parsed.positions >= lo) & (parsed.positions <= hi))
    assert np.all(np.abs(parsed.velocities) <= robot.velocity_limits * (1 + 1e-9))
    return diag


@pytest.mark.parametrize("method", METHODS)
def test_ur5_line_keeps_the_bound(client, method):
    request = ur5_request(method)
    response = client.post(URL, json=request)
    assert response.status_code == 200, response.text
    check_body(request, response.json())


def test_nlp_needs_fewer_knots_than_taylor(client):
    counts = {}
    for method in METHODS:
        response = client.post(URL, json=ur5_request(method))
        assert response.status_code == 200, response.text
        counts[method] = response.json()["diagnostics"]["knot_count"]
    assert counts["bounded_deviation_nlp"] < counts["bounded_deviation"]


@pytest.mark.parametrize("method", METHODS)
def test_goal_as_positions_and_ros_time_format(client, method):
    robot = registry.get("ur5")
    goal = (robot.home + np.array([0.3, -0.2, 0.25, -0.1, 0.2, 0.3])).tolist()
    request = {
        "robot": "ur5",
        "start": {"positions": robot.home.tolist()},
        "goal": {"positions": goal},
        "method": method,
        "duration": 3.0,
    }
    response = client.post(URL, json=request)
    assert response.status_code == 200, response.text
    body = response.json()
    check_body(request, body)
    assert body["points"][-1]["positions"] == goal
    assert body["diagnostics"]["duration"] == pytest.approx(3.0)
    ros = client.post(URL + "?time_format=ros", json=request).json()
    check_ros_trajectory(ros, rest_to_rest=True, time_format="ros")
    stamps = [k["time_from_start"] for k in ros["knots"]]
    assert all(set(t) == {"sec", "nanosec"} and 0 <= t["nanosec"] < 10**9 for t in stamps)


@pytest.mark.parametrize("method", METHODS)
def test_planar_arm_through_its_hole_is_unreachable_or_partial(client, method):
    robot = registry.get("planar_2r")
    start = robot.ik(np.array([[1, 0, 0, 0.5], [0, 1, 0, 0.05], [0, 0, 1, 0], [0, 0, 0, 1.0]]),
                     np.array([0.0, 1.0])).positions  # fmt: skip
    T_goal = robot.fk(start)
    T_goal[:2, 3] = -0.5, 0.05  # past the base: the line crosses the unreachable disc around it
    request = {
        "robot": "planar_2r",
        "start": {"positions": start.tolist()},
        "goal": {"pose": pose_body(T_goal)},
        "method": method,
    }
    response = client.post(URL, json=request)
    assert response.status_code == 422
    assert response.headers["content-type"].startswith("application/problem+json")
    problem = response.json()
    assert problem["code"] == "unreachable" and 0.0 < problem["s"] < 1.0
    response = client.post(URL, json={**request, "allow_partial": True})
    assert response.status_code == 200, response.text
    diag = response.json()["diagnostics"]
    assert 0.0 < diag["fraction"] < problem["s"]
    assert diag["failure"]["code"] == "unreachable"
    assert response.json()["knots"][-1]["s"] == pytest.approx(diag["fraction"])


@pytest.mark.parametrize("method", METHODS)
def test_too_short_duration_is_a_joint_rate_limit(client, method):
    response = client.post(URL, json=ur5_request(method, duration=0.05))
    assert response.status_code == 422
    assert response.json()["code"] == "joint_rate_limit"


@pytest.mark.parametrize("method", METHODS)
def test_too_few_samples_for_the_bound_is_infeasible(client, method):
    response = client.post(URL, json=ur5_request(method, samples=3))
    assert response.status_code == 422
    problem = response.json()
    assert problem["code"] == "infeasible" and problem["s"] is not None


@pytest.mark.parametrize("method", METHODS)
def test_time_budget(method):
    with TestClient(create_app(Settings(time_budget_s=1e-9))) as slow:
        response = slow.post(URL, json=ur5_request(method))
    assert response.status_code == 422
    assert response.json()["code"] == "time_budget_exceeded"
