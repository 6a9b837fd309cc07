"""``POST /v1/trajectories/collision_free`` (API.md, "Collision-free motions").

Every returned motion is re-checked here, independently of the planner: coal's distances (through
pinocchio, every pair) at every returned point and at ``SWEEP`` points between consecutive ones,
and the continuous check of the numpy engine (the motion bound between the returned points:
``CollisionChecker.check_path``). The failures are the documented codes, the answer is the same
for the same request and seed, in a fresh process too."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from bench import mbm
from robots import registry
from robots.collision import CollisionChecker
from service.convert.environment import collision_check
from service.schemas.environment import Environment
from tests.service.conftest import pose_body
from tests.service.helpers import problem

URL = "/v1/trajectories/collision_free"
ROOT = Path(__file__).resolve().parents[2]
SWEEP = 10
"""Points checked with coal between two consecutive returned points."""
PROBLEMS = {p.name: p for p in mbm.problems(2)}


def checker(robot_ref: Any, env: dict[str, Any] | None) -> CollisionChecker:
    robot = registry.resolve(robot_ref)
    urdf = robot_ref.get("urdf") if isinstance(robot_ref, dict) else None
    check = collision_check(robot, Environment.model_validate(env or {}), urdf)
    assert check is not None
    return check


def coal_sweep_margin(check: CollisionChecker, qs: np.ndarray) -> float:
    """Smallest margin over the thresholds (obstacle pairs: the clearance, self pairs: 0) of coal's
    distances at the returned points and ``SWEEP`` points between each consecutive two."""
    gm, names = check.geometry_model()
    links = set(check.robot.frame_names())
    thr = {n: t for n, t in zip(check.pair_names, check.threshold, strict=True)}
    model, data = check.robot.model, pin.Data(check.robot.model)
    groups = []
    for obstacle in (True, False):
        gd = pin.GeometryData(gm)
        gd.deactivateAllCollisionPairs()
        level = 0.0
        for k, (a, b) in enumerate(names):
            if (b not in links) == obstacle:
                gd.activateCollisionPair(k)
                level = thr[(a, b)]
        groups.append((gd, level))
    t = np.linspace(0.0, 1.0, SWEEP + 2)[:-1, None]
    dense = np.vstack([a + t * (b - a) for a, b in itertools.pairwise(qs)] + [qs[-1:]])
    low = np.inf
    for q in dense:
        for gd, level in groups:
            k = pin.computeDistances(model, data, gm, gd, q)
            if k < len(gd.distanceResults):
                low = min(low, gd.distanceResults[k].min_distance - level)
    return float(low)


def assert_certified(check: CollisionChecker, body: dict[str, Any]) -> None:
    qs = np.array([p["positions"] for p in body["points"]])
    times = np.array([p["time_from_start"] for p in body["points"]])
    assert coal_sweep_margin(check, qs) >= 0.0
    result = check.check_path(times, qs)
    assert result.contact is None
    assert body["diagnostics"]["certified"] is True
    assert body["diagnostics"]["min_clearance"] == pytest.approx(result.min_clearance, abs=1e-9)
    profile = body["diagnostics"]["clearance_profile"]
    rows = np.searchsorted(times, profile["time_from_start"])
    np.testing.assert_allclose(profile["value"], check.min_distances(qs[rows]), atol=1e-5)
    assert min(profile["value"]) >= result.min_clearance - 1e-5


def assert_exact_derivatives(body: dict[str, Any], limits: dict[str, list[float]]) -> None:
    t = np.array([p["time_from_start"] for p in body["points"]])
    q = np.array([p["positions"] for p in body["points"]])
    qd = np.array([p["velocities"] for p in body["points"]])
    qdd = np.array([p["accelerations"] for p in body["points"]])
    assert np.all(np.diff(t) > 0)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-9)
    assert np.all(np.abs(qd) <= np.array(limits["velocity"]) * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= np.array(limits["acceleration"]) * (1 + 1e-9))
    # trapezoid rule: positions are the integral of the velocities (to the second order in dt)
    integral = q[0] + np.vstack(
        [np.zeros(q.shape[1]), np.cumsum((qd[1:] + qd[:-1]) / 2 * np.diff(t)[:, None], axis=0)]
    )
    assert np.abs(integral - q).max() < 1e-3


@pytest.mark.parametrize("name", ["box/1", "bookshelf_small/1", "table_pick/1"])
def test_mbm_problems_are_planned_around_the_obstacles(client, name: str) -> None:
    p = PROBLEMS[name]
    body = mbm.request(p)
    answer = client.post(URL, json=body)
    assert answer.status_code == 200, answer.text
    data = answer.json()
    assert_certified(checker(body["robot"], body["environment"]), data)
    robot = registry.resolve(body["robot"])
    assert_exact_derivatives(data, {"velocity": list(robot.velocity_limits),
                                    "acceleration": list(robot.acceleration_limits)})  # fmt: skip
    q = np.array([pt["positions"] for pt in data["points"]])
    np.testing.assert_array_equal(q[0], p.start)
    np.testing.assert_array_equal(q[-1], p.goal)
    diag = data["diagnostics"]
    assert diag["planner"]["name"] in ("direct", "rrt_connect") and diag["planner"]["seed"] == 0
    assert set(diag["planner"]) == {"name", "seed", "iterations", "states", "plan_time_ms",
                                    "simplify_time_ms", "smooth_time_ms"}  # fmt: skip
    w = np.array(data["waypoints"])
    np.testing.assert_array_equal(w[[0, -1]], [p.start, p.goal])
    straight = np.linalg.norm(np.array(p.goal) - p.start)
    assert diag["path_length_ratio"] == pytest.approx(diag["path_length"] / straight)
    assert diag["path_length"] >= straight - 1e-9
    assert np.linalg.norm(np.diff(q, axis=0), axis=1).sum() <= diag["path_length"] + 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("name", [f"{s}/2" for s in mbm.SCENARIOS])
def test_every_scenario(client, name: str) -> None:
    p = PROBLEMS[name]
    body = mbm.request(p, timing="jerk_limited", seed=7, limits={"jerk": [5000.0] * 7})
    answer = client.post(URL, json=body)
    if answer.status_code == 422:  # an invalid MBM problem: start or goal in collision
        assert answer.json()["code"] == "collision" and answer.json()["at"] in ("start", "goal")
        return
    assert answer.status_code == 200, answer.text
    assert_certified(checker(body["robot"], body["environment"]), answer.json())


def strip_times(body: dict[str, Any]) -> dict[str, Any]:
    diag = dict(body["diagnostics"])
    diag.pop("compute_time_ms")
    diag["planner"] = {k: v for k, v in diag["planner"].items() if not k.endswith("_ms")}
    return {**body, "diagnostics": diag}


def test_same_request_same_answer_in_a_fresh_process(client) -> None:
    body = mbm.request(PROBLEMS["box/2"], seed=11)
    first = strip_times(client.post(URL, json=body).json())
    assert strip_times(client.post(URL, json=body).json()) == first
    code = (
        "import json, sys; from fastapi.testclient import TestClient; "
        "from service.app import create_app; "
        "c = TestClient(create_app()); "
        "print(json.dumps(c.post(sys.argv[1], json=json.loads(sys.stdin.read())).json()))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, URL], input=json.dumps(body), cwd=ROOT,
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert strip_times(json.loads(out.stdout.strip().splitlines()[-1])) == first


UR5_HOME = [
    0.0,
    -1.0471975511965976,
    1.5707963267948966,
    -2.0943951023931953,
    -1.5707963267948966,
    0.0,
]


def ball_at(q: list[float], radius: float = 0.05) -> dict[str, Any]:
    """A ball around the UR5's tool at ``q``."""
    p = registry.get("ur5").fk(np.array(q))[:3, 3]
    return {"obstacles": [{"name": "ball", "shape": {"type": "sphere", "radius": radius},
                           "pose": {"position": p.tolist(), "orientation": [0, 0, 0, 1]}}]}  # fmt: skip


def test_start_or_goal_in_collision_before_any_search(client) -> None:
    goal = [0.5, -1.2, 1.8, -2.2, -1.3, 0.4]
    body = {"robot": "ur5", "start": {"positions": UR5_HOME}, "goal": {"positions": goal}}
    err = problem(
        client.post(URL, json={**body, "environment": ball_at(UR5_HOME)}), 422, "collision"
    )
    assert err["at"] == "start" and err["links"][1] == "ball" and err["distance"] < 0
    err = problem(client.post(URL, json={**body, "environment": ball_at(goal)}), 422, "collision")
    assert err["at"] == "goal" and err["links"][1] == "ball"


def test_no_path_found_names_the_planner(client) -> None:
    body = mbm.request(PROBLEMS["box/1"], max_planning_time=1e-4)
    err = problem(client.post(URL, json=body), 422, "no_path_found")
    assert err["planner"]["name"] == "rrt_connect" and err["planner"]["seed"] == 0
    assert {"iterations", "states", "plan_time_ms"} <= set(err["planner"])


def test_max_planning_time_is_at_most_the_budget(client) -> None:
    body = mbm.request(PROBLEMS["box/1"], max_planning_time=1e4)
    err = problem(client.post(URL, json=body), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "max_planning_time"]


def test_goal_pose_with_a_configuration_label(client) -> None:
    robot = registry.get("ur5")
    q_goal = np.array([0.6, -1.4, 1.9, -2.0, -1.4, 0.7])
    label = robot.configuration(q_goal)
    T = robot.fk(q_goal)
    body = {"robot": "ur5", "start": {"positions": UR5_HOME},
            "goal": {"pose": pose_body(T), "configuration": label},
            "environment": {"obstacles": [{"name": "post", "shape": {"type": "cylinder", "radius": 0.04, "length": 0.6},
                                            "pose": {"position": [-0.45, 0.1, 0.3], "orientation": [0, 0, 0, 1]}}]}}  # fmt: skip
    answer = client.post(URL, json=body)
    assert answer.status_code == 200, answer.text
    data = answer.json()
    q_end = np.array(data["points"][-1]["positions"])
    np.testing.assert_allclose(robot.fk(q_end), T, atol=1e-9)
    assert robot.configuration(q_end) == label == data["diagnostics"]["goal_configuration"]
    assert_certified(checker("ur5", body["environment"]), data)
    other = next(c for c in robot.configuration_labels if c != label)
    answer = client.post(URL, json={**body, "goal": {"pose": pose_body(T), "configuration": other}})
    assert answer.status_code in (200, 422)
    if answer.status_code == 200:
        assert robot.configuration(np.array(answer.json()["points"][-1]["positions"])) == other
    else:
        assert answer.json()["code"] == "unreachable"
    err = problem(
        client.post(URL, json={**body, "goal": {"pose": pose_body(T), "configuration": "nope"}}),
        422,
        "validation",
    )
    assert err["errors"][0]["loc"] == ["body", "goal", "configuration"]


def test_goal_pose_whose_solutions_all_collide_is_unreachable(client) -> None:
    robot = registry.get("ur5")
    q_goal = np.array([0.6, -1.4, 1.9, -2.0, -1.4, 0.7])
    T = robot.fk(q_goal)
    env = ball_at(q_goal.tolist(), radius=0.08)  # the tool is inside it for every solution
    body = {
        "robot": "ur5",
        "start": {"positions": UR5_HOME},
        "goal": {"pose": pose_body(T)},
        "environment": env,
    }
    err = problem(client.post(URL, json=body), 422, "unreachable")
    labels = {row["configuration"] for row in err["solutions"]}
    assert len(err["solutions"]) == len(robot.ik_all(T, np.array(UR5_HOME)).positions) >= 2
    assert labels <= set(robot.configuration_labels)
    assert all(row["distance"] < 0 and len(row["links"]) == 2 for row in err["solutions"])


def test_without_environment_the_direct_segment(client) -> None:
    goal = [0.5, -1.2, 1.8, -2.2, -1.3, 0.4]
    body = {
        "robot": "ur5",
        "start": {"positions": UR5_HOME},
        "goal": {"positions": goal},
        "samples": 50,
    }
    data = client.post(URL, json=body).json()
    assert data["diagnostics"]["planner"]["name"] == "direct"
    assert data["waypoints"] == [UR5_HOME, goal]
    # the 50 samples asked, plus a pair of points around each switch of the time-optimal law
    times = np.array([p["time_from_start"] for p in data["points"]])
    asked = np.linspace(0.0, times[-1], 50)
    assert len(times) >= 50 and np.abs(times[:, None] - asked).min(axis=0).max() <= 1e-6


def test_jerk_limited_keeps_the_jerk_limits(client) -> None:
    p = PROBLEMS["box/1"]
    jerk = [200.0] * 7
    body = mbm.request(p, timing="jerk_limited", limits={"jerk": jerk}, sample_period=0.002)
    answer = client.post(URL, json=body)
    assert answer.status_code == 200, answer.text
    data = answer.json()
    assert data["diagnostics"]["timing"] == "jerk_limited"
    t = np.array([pt["time_from_start"] for pt in data["points"]])
    qdd = np.array([pt["accelerations"] for pt in data["points"]])
    assert np.all(np.abs(np.diff(qdd, axis=0)) / np.diff(t)[:, None] <= np.array(jerk) * (1 + 1e-6))
    assert_certified(checker(body["robot"], body["environment"]), data)
    err = problem(client.post(URL, json={**body, "robot": "ur5", "start": {"positions": UR5_HOME},
                                          "goal": {"positions": UR5_HOME}, "limits": None,
                                          "environment": None}), 422, "validation")  # fmt: skip
    assert err["errors"][0]["loc"][:3] == ["body", "limits", "jerk"]


def test_nothing_to_collide_with_is_the_direct_segment(client) -> None:
    goal = [0.5, -1.2, 1.8, -2.2, -1.3, 0.4]
    body = {"robot": "ur5", "start": {"positions": UR5_HOME}, "goal": {"positions": goal},
            "environment": {"self_collision": False}}  # fmt: skip
    data = client.post(URL, json=body).json()
    assert data["diagnostics"]["planner"]["name"] == "direct"
    assert "min_clearance" not in data["diagnostics"] and data["diagnostics"]["certified"] is True
    same = client.post(URL, json={**body, "goal": {"positions": UR5_HOME}}).json()
    assert (
        same["diagnostics"]["path_length"] == 0.0
        and same["diagnostics"]["path_length_ratio"] == 1.0
    )
    assert all(p["positions"] == UR5_HOME for p in same["points"])


def test_a_start_at_the_base_in_collision_names_the_allowed_pair(client, monkeypatch) -> None:
    """The pipeline's one check (``core.collisions.check_ends``): 422 ``collision`` at the start
    with the pair and, for a link at the base, the allowed_collisions hint; nothing searched."""

    def never(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("searched although the start is in collision")

    monkeypatch.setattr("core.motion.plan.find_path", never)
    table = {"name": "table", "shape": {"type": "halfspace", "normal": [0, 0, 1], "offset": 0.02}}
    goal = [0.5, -1.2, 1.8, -2.2, -1.3, 0.4]
    body = {"robot": "ur5", "start": {"positions": UR5_HOME}, "goal": {"positions": goal},
            "environment": {"obstacles": [table]}}  # fmt: skip
    err = problem(client.post(URL, json=body), 422, "collision")
    assert err["at"] == "start" and err["links"] == ["shoulder_link", "table"]
    assert err["distance"] < 0 and err["time_from_start"] == 0.0
    assert 'environment.allowed_collisions, e.g. [["shoulder_link", "table"]]' in err["detail"]


def test_a_tool_offset_moves_the_goal_pose_to_the_tool_frame(client) -> None:
    robot = registry.get("ur5")
    tool = {"position": [0.0, 0.0, 0.12], "orientation": [0.0, 0.0, 0.38268343, 0.92387953]}
    T_tool = pose_matrix(tool)
    q_goal = np.array([0.6, -1.4, 1.9, -2.0, -1.4, 0.7])
    T_goal = robot.fk(q_goal) @ T_tool  # the tool frame's pose at q_goal
    body = {"robot": "ur5", "tool": tool, "start": {"positions": UR5_HOME},
            "goal": {"pose": pose_body(T_goal)}, "environment": ball_at(UR5_HOME, 0.02)}  # fmt: skip
    body["environment"]["obstacles"][0]["pose"]["position"][2] += 0.3  # out of the way
    answer = client.post(URL, json=body)
    assert answer.status_code == 200, answer.text
    q_end = np.array(answer.json()["points"][-1]["positions"])
    np.testing.assert_allclose(robot.fk(q_end) @ T_tool, T_goal, atol=1e-9)
    without = client.post(URL, json={k: v for k, v in body.items() if k != "tool"})
    if without.status_code == 200:  # the tip frame at T_goal: another configuration
        q_tip = np.array(without.json()["points"][-1]["positions"])
        np.testing.assert_allclose(robot.fk(q_tip), T_goal, atol=1e-9)
    bad = client.post(
        URL, json={**body, "tool": {"position": [0, 0, 99], "orientation": [0, 0, 0, 1]}}
    )
    assert problem(bad, 422, "validation")["errors"][0]["loc"][:2] == ["body", "tool"]


def pose_matrix(pose: dict[str, Any]) -> np.ndarray:
    """``(4, 4)`` of a position and an x, y, z, w quaternion (pinocchio's quaternion type)."""
    x, y, z, w = pose["orientation"]
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    T[:3, 3] = pose["position"]
    return T


def test_a_panda_goal_pose_reachable_only_with_joint_7_elsewhere(client) -> None:
    """A redundant arm's goal pose: the hand pointing forward at (0.7, 0.1, 0.4) has no solution
    with panda_joint7 at the start's pi/4 (/v1/ik with ``all`` says so), yet many with it
    elsewhere: the planner gathers them (was 422 unreachable) and reaches the pose (pinocchio)."""
    panda = registry.get("panda")
    pose = {"position": [0.7, 0.1, 0.4], "orientation": [0.0, 0.5**0.5, 0.0, 0.5**0.5]}
    held = client.post(
        "/v1/ik", json={"robot": "panda", "pose": pose, "seed": panda.home.tolist(), "all": True}
    )
    assert problem(held, 422, "unreachable")["redundant_joints"] == ["panda_joint7"]
    answer = client.post(
        URL,
        json={
            "robot": "panda",
            "start": {"positions": panda.home.tolist()},
            "goal": {"pose": pose},
        },
    )
    assert answer.status_code == 200, answer.text
    q_end = np.array(answer.json()["points"][-1]["positions"])
    model, data = panda.model, panda.model.createData()
    pin.framesForwardKinematics(model, data, q_end)
    np.testing.assert_allclose(
        data.oMf[model.getFrameId(panda.tip_frame)].homogeneous, pose_matrix(pose), atol=1e-9
    )
    limits = panda.position_limits
    assert np.all((q_end >= limits[:, 0]) & (q_end <= limits[:, 1]))
