"""POST /v1/trajectories/cartesian over HTTP: the trajectory shape, diagnostics, every error code.

The tool's distance from the line is checked here from the robot's forward kinematics of the
returned points (``fk_many``), not read from the diagnostics.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from core.cartesian.methods import METHODS
from core.geometry.so3 import pose_to_matrix
from robots import registry
from service.app import create_app
from service.schemas.cartesian import Method
from service.schemas.registry import names_of
from service.settings import Settings
from tests.core.conftest import offset_move
from tests.ros_rules import check_ros_trajectory
from tests.service.conftest import pose_body
from tests.toy_kinematics import FlippingToy

URL = "/v1/trajectories/cartesian"
UR5_HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
UR5_GOAL = [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]
UR5_LINE = {
    "robot": "ur5",
    "start": {"positions": UR5_HOME},
    "goal": {"positions": UR5_GOAL},
    "method": "sampled",
}
HOLE_START = [2.183947650, 2.243927860]  # the planar arm's tip at (-0.8, 0.05)
HOLE_LINE = {
    "robot": "planar_2r",
    "start": {"positions": HOLE_START},
    "goal": {"pose": {"position": [0.8, 0.05, 0.0], "orientation": [0, 0, 0, 1]}},
    "method": "sampled",
}
S_HOLE = (0.8 - math.sqrt(0.2**2 - 0.05**2)) / 1.6


def problem(response, status: int, code: str) -> dict:
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["code"] == code and body["status"] == status, body
    assert body["type"].endswith("/" + code)
    return body


def tool_errors(request: dict, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] and angle [rad] of the tool from the request's line at each row."""
    robot = registry.get(request["robot"])
    T0 = robot.fk(np.array(request["start"]["positions"]))
    goal = request["goal"]
    if "positions" in goal:
        T1 = robot.fk(np.array(goal["positions"]))
    else:
        T1 = pose_to_matrix(
            np.array(goal["pose"]["position"]), np.array(goal["pose"]["orientation"])
        )
    rows = slice(0, 2) if robot.task_space == "position_xy" else slice(0, 3)
    T = robot.fk_many(positions)
    p0, d = T0[rows, 3], T1[rows, 3] - T0[rows, 3]
    s = np.clip((T[:, rows, 3] - p0) @ d / (d @ d), 0, 1)
    position = np.linalg.norm(T[:, rows, 3] - (p0 + s[:, None] * d), axis=1)
    if robot.task_space == "position_xy":
        return position, np.zeros(len(s))
    R0 = Rotation.from_matrix(T0[:3, :3])
    rotvec = (R0.inv() * Rotation.from_matrix(T1[:3, :3])).as_rotvec()
    R_line = R0 * Rotation.from_rotvec(s[:, None] * rotvec)
    return position, (R_line.inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()


def test_ur5_line_is_a_ros_trajectory_on_the_line(client):
    response = client.post(URL, json=UR5_LINE)
    assert response.status_code == 200, response.text
    body = response.json()
    parsed = check_ros_trajectory(body, rest_to_rest=True)
    position, orientation = tool_errors(UR5_LINE, parsed.positions)
    assert position.max() <= 1e-6 and orientation.max() <= 1e-6
    assert parsed.positions[-1].tolist() == UR5_GOAL
    robot = registry.get("ur5")
    assert np.all(np.abs(parsed.velocities) <= robot.velocity_limits * (1 + 1e-9))
    assert body["joint_names"] == list(robot.joint_names)
    diag = body["diagnostics"]
    assert diag["method"] == "sampled" and diag["fraction"] == 1.0
    assert 0 <= diag["max_position_deviation"] <= 1e-3
    assert 0 <= diag["max_orientation_deviation"] <= 1e-2
    assert diag["min_singular_value"] > 0.1
    assert "failure" not in diag and "knots" not in body
    grid = np.arange(0.0, parsed.times[-1], 0.01)  # the regular points, plus switch pairs
    gaps = np.abs(parsed.times[:, None] - grid[None, :]).min(axis=0)
    assert gaps.max() <= 1e-9 and np.diff(parsed.times).min() >= 0.99e-6
    profile = diag["deviation_profile"]
    assert 2 <= len(profile["s"]) <= 256 and len(profile["position"]) == len(profile["s"])
    assert max(profile["position"]) == pytest.approx(diag["max_position_deviation"])
    sv = diag["singular_value_profile"]
    assert min(sv["value"]) == pytest.approx(diag["min_singular_value"])


def test_ros_time_format_and_samples(client):
    request = {**UR5_LINE, "samples": 5, "duration": 3.0}
    body = client.post(URL, json=request, params={"time_format": "ros"}).json()
    parsed = check_ros_trajectory(body, rest_to_rest=True, time_format="ros")
    assert len(parsed.times) == 5 and body["points"][-1]["time_from_start"] == {
        "sec": 3,
        "nanosec": 0,
    }
    position, _ = tool_errors(request, parsed.positions)
    assert position.max() <= 1e-6


def test_pose_goal_with_rotation_on_the_panda(client):
    panda = registry.get("panda")
    T0 = panda.fk(panda.home)
    R = Rotation.from_rotvec([0.0, 0.0, 0.6]) * Rotation.from_matrix(T0[:3, :3])
    request = {
        "robot": "panda",
        "start": {"positions": panda.home.tolist()},
        "goal": {
            "pose": {
                "position": (T0[:3, 3] + [0.1, 0.15, -0.1]).tolist(),
                "orientation": R.as_quat().tolist(),
            }
        },
        "method": "sampled",
        "tolerance": {"position": 0.0005, "orientation": 0.005},
    }
    body = client.post(URL, json=request).json()
    parsed = check_ros_trajectory(body, rest_to_rest=True)
    position, orientation = tool_errors(request, parsed.positions)
    assert position.max() <= 1e-6 and orientation.max() <= 1e-6
    T_end = panda.fk(parsed.positions[-1])
    assert np.linalg.norm(T_end[:3, 3] - request["goal"]["pose"]["position"]) <= 1e-6
    assert (Rotation.from_matrix(T_end[:3, :3]).inv() * R).magnitude() <= 1e-6


def test_planar_hole_unreachable_and_partial(client):
    body = problem(client.post(URL, json=HOLE_LINE), 422, "unreachable")
    assert abs(body["s"] - S_HOLE) <= 0.02
    response = client.post(URL, json={**HOLE_LINE, "allow_partial": True})
    assert response.status_code == 200
    partial = response.json()
    parsed = check_ros_trajectory(partial, rest_to_rest=True)
    diag = partial["diagnostics"]
    assert abs(diag["fraction"] - S_HOLE) <= 0.02 and diag["fraction"] <= body["s"]
    assert diag["failure"]["code"] == "unreachable" and diag["failure"]["s"] == body["s"]
    assert diag["warnings"][0].startswith("planned 37.9% of the line")
    position, _ = tool_errors(HOLE_LINE, parsed.positions)
    assert position.max() <= 1e-6


def test_every_method_name_is_passed_to_the_planner(client):
    assert set(names_of(Method)) == set(METHODS)
    for method in METHODS:
        response = client.post(URL, json={**UR5_LINE, "method": method, "samples": 20})
        assert response.status_code in (200, 422), (method, response.text)
        body = response.json()
        if response.status_code == 200:
            assert body["diagnostics"]["method"] == method
            assert "fraction" in body["diagnostics"]
            if "knots" in body:
                assert body["diagnostics"]["knot_count"] == len(body["knots"])
                assert set(body["knots"][0]) == {"s", "time_from_start", "positions"}
        else:  # a method not there yet is refused by the core's dispatch, not by the schema
            assert not any(e["loc"][-1] == "method" for e in body.get("errors", [])) or (
                body["code"] == "validation" and "method must be one of" in body["detail"]
            )


# --- every error code of this endpoint ------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "loc"),
    [
        ({"duration": 2.0, "max_linear_speed": 0.1}, ["body"]),
        ({"samples": 10, "sample_period": 0.01}, ["body"]),
        ({"goal": {"positions": UR5_GOAL, "pose": HOLE_LINE["goal"]["pose"]}}, ["body", "goal"]),
        ({"goal": {}}, ["body", "goal"]),
        ({"method": "teleport"}, ["body", "method"]),
        ({"tolerance": {"position": 0.0}}, ["body", "tolerance", "position"]),
        ({"duration": -1.0}, ["body", "duration"]),
        ({"control_period": 1.0}, ["body", "control_period"]),
        ({"samples": 1}, ["body", "samples"]),
        ({"unknown": 1}, ["body", "unknown"]),
        ({"start": {"positions": UR5_HOME[:5]}}, ["body", "start", "positions"]),
        ({"goal": {"positions": [0.0] * 7}}, ["body", "goal", "positions"]),
    ],
)
def test_validation(client, change, loc):
    body = problem(client.post(URL, json={**UR5_LINE, **change}), 422, "validation")
    assert any(e["loc"][: len(loc)] == loc for e in body["errors"]), body["errors"]


def test_non_finite_numbers_are_validation(client):
    raw = (
        '{"robot": "ur5", "start": {"positions": [0, 0, 0, 0, 0, NaN]}, '
        '"goal": {"positions": [0, 0, 0, 0, 0, 1]}, "method": "sampled"}'
    )
    response = client.post(URL, content=raw, headers={"content-type": "application/json"})
    body = problem(response, 422, "validation")
    assert body["errors"][0]["loc"] == ["body", "start", "positions", 5]
    assert "nan" not in response.text.lower()  # the offending value is never echoed


def test_unknown_robot_and_invalid_urdf(client):
    problem(client.post(URL, json={**UR5_LINE, "robot": "r2d2"}), 404, "unknown_robot")
    inline = {
        "urdf": "<robot name='x'><link name='a'/></robot>",
        "tip_frame": "b",
        "base_frame": "a",
    }
    problem(client.post(URL, json={**UR5_LINE, "robot": inline}), 422, "invalid_urdf")


def test_joint_limit(client):
    puma = {"robot": "puma560", "method": "sampled"}
    start = [0.0, math.pi / 4, -math.pi, 0.0, 3.0, 0.0]  # q5 outside +-1.75 rad
    body = problem(
        client.post(
            URL, json={**puma, "start": {"positions": start}, "goal": {"positions": [0] * 6}}
        ),
        422,
        "joint_limit",
    )
    assert body["s"] == 0.0 and body["errors"][0]["loc"] == ["body", "start", "positions", 4]
    # Turning the wrist by pi from q4 = 0.05 would need q4 beyond its limit of 2.97 rad.
    along = {
        **puma,
        "start": {"positions": [0.0, math.pi / 4, -math.pi, 0.05, 0.1, -0.05]},
        "goal": {"positions": [0.05, math.pi / 4, -math.pi, -0.05, -0.1, 0.05]},
    }
    body = problem(client.post(URL, json=along), 422, "joint_limit")
    assert 0.5 < body["s"] < 0.9


def test_singularity(client):
    through = {
        "robot": "puma560",
        "start": {"positions": [0.0, math.pi / 4, -math.pi, 0.0, 0.3, 0.0]},
        "goal": {"positions": [0.0, math.pi / 4, -math.pi, 0.0, -0.3, 0.0]},
        "method": "sampled",
    }
    body = problem(client.post(URL, json=through), 422, "singularity")
    assert 0.4 < body["s"] < 0.6
    stretched = {**HOLE_LINE, "start": {"positions": [0.3, 0.0]}}
    assert problem(client.post(URL, json=stretched), 422, "singularity")["s"] == 0.0


def test_joint_rate_limit_and_the_same_line_under_speed_limits(client):
    body = problem(client.post(URL, json={**UR5_LINE, "duration": 0.1}), 422, "joint_rate_limit")
    assert 0 < body["s"] < 1 and body["min_duration"] > 0.1
    assert body["errors"][0]["loc"] == ["body", "duration"]
    fine = client.post(URL, json={**UR5_LINE, "max_linear_speed": 1.0, "max_angular_speed": 3.0})
    assert fine.status_code == 200
    velocities = np.array([p["velocities"] for p in fine.json()["points"]])
    assert np.all(np.abs(velocities) <= registry.get("ur5").velocity_limits * (1 + 1e-9))


def test_too_large_and_infeasible(client):
    body = problem(
        client.post(URL, json={**UR5_LINE, "duration": 1000.0, "sample_period": 1e-3}),
        422,
        "too_large",
    )
    assert "100000" in body["detail"].replace(",", "")
    slow = {**UR5_LINE, "max_linear_speed": 1e-6, "max_angular_speed": 1e-6}
    problem(client.post(URL, json=slow), 422, "infeasible")


def test_time_budget_exceeded():
    with TestClient(create_app(Settings(time_budget_s=1e-9))) as c:
        problem(c.post(URL, json=UR5_LINE), 422, "time_budget_exceeded")


def test_branch_flip(client, monkeypatch):
    monkeypatch.setattr(registry, "resolve", lambda ref: FlippingToy())
    request = {
        "robot": "planar_2r",
        "start": {"positions": [0.2, 1.4]},
        "goal": {"pose": {"position": [1.3, 0.5, 0.0], "orientation": [0, 0, 0, 1]}},
        "method": "sampled",
    }
    body = problem(client.post(URL, json=request), 422, "branch_flip")
    assert 0.2 < body["s"] < 0.8 and "another branch" in body["detail"]


def test_openapi_documents_the_endpoint(client):
    spec = client.get("/openapi.json").json()
    assert "/v1/trajectories/cartesian" in spec["paths"]
    props = spec["components"]["schemas"]["CartesianRequest"]["properties"]
    for name in ("robot", "start", "goal", "method", "tolerance", "duration", "max_linear_speed",
                 "max_angular_speed", "sample_period", "samples", "control_period",
                 "allow_partial", "solver"):  # fmt: skip
        assert name in props
    for name in ("duration", "max_linear_speed", "samples", "control_period"):
        assert props[name].get("description")


def _panda_line(**extra) -> dict:
    """Issue 19's repro: a Panda line (0.27 m, 30 degrees) timed tightly or sampled sparsely."""
    panda = registry.get("panda")
    T = offset_move(panda, panda.home, np.array([0.2, 0.1, -0.15]), (1.0, 0.0, 1.0), np.radians(30))
    body = {
        "robot": "panda",
        "start": {"positions": panda.home.tolist()},
        "goal": {"pose": pose_body(T)},
        "method": "sampled",
    }
    return {**body, **extra}


@pytest.mark.parametrize(
    ("extra", "code"),
    [
        ({"duration": 0.71, "sample_period": 0.05}, "joint_rate_limit"),  # accelerations 1.2x
        ({"duration": 2.0, "samples": 4}, "infeasible"),  # 2.6 mm between 4 points
    ],
)
def test_a_200_is_within_tolerance_and_limits_unless_violations_are_allowed(client, extra, code):
    body = problem(client.post(URL, json=_panda_line(**extra)), 422, code)
    assert "allow_violations" in body["detail"]
    allowed = client.post(URL, json=_panda_line(allow_violations=True, **extra))
    assert allowed.status_code == 200, allowed.text
    assert allowed.json()["diagnostics"]["warnings"], "an accepted violation is reported"


# --- issue 14: lines keep their start's configuration ---------------------------------------------

LABELLED_METHODS = ("sampled", "bounded_deviation", "bounded_deviation_nlp")


def planar_ik(x: float, y: float, elbow: float) -> list[float]:
    """The planar arm's joint positions with its tip at (x, y); ``elbow`` +1 (label down) or -1."""
    q2 = elbow * math.acos((x * x + y * y - 1.64) / 1.6)
    q1 = math.atan2(y, x) - math.atan2(0.8 * math.sin(q2), 1.0 + 0.8 * math.cos(q2))
    return [q1, q2]


def rim_s(p0, p1, reach: float = 1.8) -> float:
    """Analytic s in [0, 1] where |p0 + s (p1 - p0)| = reach (the line leaves the disc)."""
    p0, d = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float) - np.asarray(p0, dtype=float)
    a, b, c = d @ d, 2.0 * p0 @ d, p0 @ p0 - reach**2
    return float((-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a))


@pytest.mark.parametrize("method", (*LABELLED_METHODS, "resolved_rate", "resolved_rate_dls"))
@pytest.mark.parametrize("elbow", [1.0, -1.0])
@pytest.mark.parametrize(
    ("p0", "p1"),
    [  # an oblique and a radial line in the default run; all six (60 plans, 2 min) in -m slow
        ((0.3, 0.8), (2.5, 0.0)),
        ((1.0, 0.0), (3.0, 0.0)),
        pytest.param((0.0, 1.0), (0.0, 3.0), marks=pytest.mark.slow),
        pytest.param((0.5, 0.0), (2.1, 0.0), marks=pytest.mark.slow),
        pytest.param((1.0, 0.5), (2.5, 0.5), marks=pytest.mark.slow),
        pytest.param((0.5, 0.5), (2.0, 2.0), marks=pytest.mark.slow),
    ],
)
def test_planar_line_off_the_outer_rim_is_unreachable_where_the_reach_ends(
    client, method, elbow, p0, p1
):
    """Issue 14's defect: a radial line off the rim answered branch_flip (the elbow stretches to
    q2 = 0, where the labels meet); it is unreachable at the s where |p(s)| = l1 + l2."""
    request = {
        "robot": "planar_2r",
        "start": {"positions": planar_ik(*p0, elbow)},
        "goal": {"pose": {"position": [*p1, 0.0], "orientation": [0, 0, 0, 1]}},
        "method": method,
    }
    body = problem(client.post(URL, json=request), 422, "unreachable")
    assert abs(body["s"] - rim_s(p0, p1)) <= 0.01, body
    assert rim_s(p0, p1) - 1e-3 <= body["s"]  # never before the rim


UR5_LABEL_START = np.array(UR5_HOME)


def ur5_outward_line(method: str, reach: float) -> dict:
    """A UR5 line from home, the tool moving ``reach`` [m] outward (-x of the base; home's tool is
    at x = -0.647 m), its orientation held."""
    robot = registry.get("ur5")
    T_goal = robot.fk(UR5_LABEL_START)
    T_goal[0, 3] -= reach
    return {
        "robot": "ur5",
        "start": {"positions": UR5_HOME},
        "goal": {"pose": pose_body(T_goal)},
        "method": method,
    }


def first_unsolvable_s(robot, T0: np.ndarray, reach: float) -> float:
    """Reference: bisection on s of the first pose of the line without any IK solution (EAIK,
    verified by FK), independent of the planners."""
    lo, hi = 0.0, 1.0
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        T = T0.copy()
        T[0, 3] -= mid * reach
        sols = robot.ik_all(T, UR5_LABEL_START)
        lo, hi = (mid, hi) if len(sols.positions) or sols.outside_limits else (lo, mid)
    return hi


@pytest.mark.parametrize("method", LABELLED_METHODS)
def test_ur5_line_leaving_the_workspace_is_unreachable_at_its_s(client, method):
    robot = registry.get("ur5")
    request = ur5_outward_line(method, 0.8)
    s_true = first_unsolvable_s(robot, robot.fk(UR5_LABEL_START), 0.8)
    assert 0.1 < s_true < 0.9
    body = problem(client.post(URL, json=request), 422, "unreachable")
    assert abs(body["s"] - s_true) <= 0.01, (body, s_true)


class ElbowLosingUR5:
    """The UR5 whose start configuration's solutions (and only those) cease to exist once the tool
    passes x = ``x_cut`` [m] outward: a pose there has the other seven labels only, so a line keeping the
    start's label must flip its branch at the s where it crosses x_cut."""

    def __init__(self, x_cut: float) -> None:
        self._robot, self._x_cut = registry.get("ur5"), x_cut
        self._label = self._robot.configuration(UR5_LABEL_START)

    def __getattr__(self, name):
        return getattr(self._robot, name)

    def _cut(self, T: np.ndarray) -> bool:
        return bool(T[0, 3] < self._x_cut)

    def ik_all(self, T, seed=None, *args, **kwargs):
        sols = self._robot.ik_all(T, seed, *args, **kwargs)
        if not self._cut(T):
            return sols
        keep = np.array([c != self._label for c in sols.configurations], dtype=bool)
        labels = tuple(c for c in sols.configurations if c != self._label)
        return type(sols)(
            sols.positions[keep], labels, sols.position_errors[keep],
            sols.orientation_errors[keep], sols.solver, sols.warnings, sols.outside_limits,
        )  # fmt: skip

    def ik_many(self, Ts, seed, configuration=None):
        path = self._robot.ik_many(Ts, seed, configuration)
        kept = np.array([not self._cut(T) for T in Ts]) | (configuration != self._label)
        return dataclasses.replace(
            path, found=path.found & kept, within_limits=path.within_limits & kept
        )

    def ik(self, T, seed, **kwargs):
        r = self._robot.ik(T, seed, **kwargs)
        if self._cut(T) and self._robot.configuration(r.positions) == self._label:
            other = self.ik_all(T, seed).positions[0]  # IK lands on another branch
            return r._replace(positions=other)
        return r


@pytest.mark.parametrize("method", LABELLED_METHODS)
def test_ur5_line_that_needs_another_configuration_is_a_branch_flip_at_its_s(
    client, monkeypatch, method
):
    robot = registry.get("ur5")
    x0 = robot.fk(UR5_LABEL_START)[0, 3]
    fake = ElbowLosingUR5(x_cut=x0 - 0.06)
    monkeypatch.setattr(registry, "resolve", lambda ref: fake)
    body = problem(client.post(URL, json=ur5_outward_line(method, 0.1)), 422, "branch_flip")
    assert abs(body["s"] - 0.6) <= 0.01, body
    assert f"than the start's ({fake._label})" in body["detail"], body


@pytest.mark.parametrize("method", LABELLED_METHODS)
def test_goal_positions_in_another_configuration_are_named_in_the_warning(client, method):
    """goal.positions on another label than the start's: the line keeps the start's and ends on
    the start label's solution of the goal pose (FK equal to the goal pose, label the start's)."""
    robot = registry.get("ur5")
    start = robot.configuration(np.array(UR5_HOME))
    T_goal = robot.fk(np.array(UR5_GOAL))
    sols = robot.ik_all(T_goal, np.array(UR5_GOAL))
    other = next(q for q, c in zip(sols.positions, sols.configurations, strict=True) if c != start)
    request = {**UR5_LINE, "goal": {"positions": other.tolist()}, "method": method}
    response = client.post(URL, json=request)
    assert response.status_code == 200, response.text
    body = response.json()
    note = f"goal.positions are {robot.configuration(other)}, the line keeps the start's {start}"
    warnings = body["diagnostics"]["warnings"]
    assert any(note in w for w in warnings), warnings
    end = np.array(body["points"][-1]["positions"])
    assert robot.configuration(end) == start
    assert np.abs(robot.fk(end) - T_goal).max() <= 1e-6
