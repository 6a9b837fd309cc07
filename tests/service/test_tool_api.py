"""``tool`` (a TCP offset) on every request that names a robot: FK, IK, lines and programs refer to the
tool frame. Measured independently: pinocchio FK of the untouched model times the offset."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from core.geometry.so3 import matrix_to_quat
from robots import registry
from service.app import create_app
from tests.service.helpers import problem

UR5 = registry.get("ur5")
T_TOOL = np.eye(4)
T_TOOL[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.4, 0.2)
T_TOOL[:3, 3] = [0.02, -0.03, 0.18]
TOOL = {"position": T_TOOL[:3, 3].tolist(), "orientation": matrix_to_quat(T_TOOL[:3, :3]).tolist()}


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def tool_pose(q) -> np.ndarray:
    """pinocchio FK of the UR5's own model (tool0, the tip) times the offset."""
    model = UR5.model
    data = pin.Data(model)
    pin.forwardKinematics(model, data, np.asarray(q, dtype=float))
    tip = model.getFrameId("tool0", pin.FrameType.BODY)
    return pin.updateFramePlacement(model, data, tip).homogeneous @ T_TOOL


def pose_body(T: np.ndarray) -> dict:
    return {"position": T[:3, 3].tolist(), "orientation": matrix_to_quat(T[:3, :3]).tolist()}


def as_matrix(pose: dict) -> np.ndarray:
    x, y, z, w = pose["orientation"]
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(w, x, y, z).toRotationMatrix()
    T[:3, 3] = pose["position"]
    return T


def test_fk_answers_for_the_tool_frame(client) -> None:
    q = (UR5.home + np.array([0.3, -0.2, 0.1, 0.4, -0.3, 0.5])).tolist()
    for path, body in (
        ("/v1/robots/ur5/fk", {"positions": q, "tool": TOOL, "frames": True}),
        ("/v1/fk", {"robot": "ur5", "positions": q, "tool": TOOL, "frames": True}),
    ):
        doc = client.post(path, json=body).json()
        np.testing.assert_allclose(as_matrix(doc["pose"]), tool_pose(q), atol=1e-12)
        plain = client.post(path, json={**body, "tool": None}).json()
        assert doc["frames"] == plain["frames"]  # link frames do not move with a tool
        assert doc["configuration"] == plain["configuration"]


def test_ik_solutions_put_the_tool_on_the_pose(client) -> None:
    q = UR5.home + np.array([0.2, 0.3, -0.4, 0.1, 0.5, -0.3])
    goal = pose_body(tool_pose(q))
    doc = client.post("/v1/robots/ur5/ik", json={"pose": goal, "tool": TOOL, "all": True}).json()
    assert doc["solver"] == "analytic" and len(doc["solutions"]) >= 4
    for sol in doc["solutions"]:
        np.testing.assert_allclose(tool_pose(sol["positions"]), tool_pose(q), atol=1e-8)
    one = client.post("/v1/ik", json={"robot": "ur5", "pose": goal, "tool": TOOL}).json()
    np.testing.assert_allclose(tool_pose(one["positions"]), tool_pose(q), atol=1e-8)


def test_a_line_moves_the_tool_point_on_the_straight_line(client) -> None:
    """A sampled line whose orientation turns 0.6 rad: the tool point (pinocchio FK times the
    offset, joints linear between the returned points) stays on the segment from the start's tool
    point to the goal's, within the tolerance; the flange does not (it swings with the tool)."""
    start = UR5.home
    T0 = tool_pose(start)
    T1 = T0.copy()
    T1[:3, :3] = T0[:3, :3] @ pin.rpy.rpyToMatrix(0.6, 0.0, 0.0)
    T1[:3, 3] += [0.1, 0.15, -0.05]
    body = {
        "robot": "ur5",
        "tool": TOOL,
        "start": {"positions": start.tolist()},
        "goal": {"pose": pose_body(T1)},
        "method": "sampled",
        "samples": 80,
    }
    doc = client.post("/v1/trajectories/cartesian", json=body).json()
    qs = np.array([p["positions"] for p in doc["points"]])
    f = np.linspace(0, 1, 11)[:-1]
    dense = np.vstack(
        [(qs[:-1, None] + f[:, None] * np.diff(qs, axis=0)[:, None]).reshape(-1, 6), qs[-1:]]
    )
    a, b = T0[:3, 3], T1[:3, 3]
    axis = (b - a) / np.linalg.norm(b - a)

    def off_line(points: np.ndarray) -> np.ndarray:
        rel = points - a
        return np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)

    tool = np.array([tool_pose(q)[:3, 3] for q in dense])
    assert off_line(np.array([tool_pose(q)[:3, 3] for q in qs])).max() < 1e-8
    assert off_line(tool).max() <= 1e-3
    np.testing.assert_allclose(tool_pose(qs[-1]), T1, atol=1e-8)
    assert doc["diagnostics"]["max_position_deviation"] <= 1e-3
    flange = np.array([(tool_pose(q) @ np.linalg.inv(T_TOOL))[:3, 3] for q in qs])
    f0, f1 = flange[0], flange[-1]
    rel = flange - f0
    u = (f1 - f0) / np.linalg.norm(f1 - f0)
    assert np.linalg.norm(rel - np.outer(rel @ u, u), axis=1).max() > 5e-3


def test_a_program_lin_ends_with_the_tool_on_its_goal(client) -> None:
    T1 = tool_pose(UR5.home)
    T1[:3, 3] += [0.0, 0.1, 0.05]
    body = {
        "robot": "ur5",
        "tool": TOOL,
        "start": {"positions": UR5.home.tolist()},
        "segments": [{"type": "lin", "goal": {"pose": pose_body(T1)}}],
    }
    doc = client.post("/v1/trajectories/program", json=body).json()
    np.testing.assert_allclose(tool_pose(doc["points"][-1]["positions"]), T1, atol=1e-8)


def test_every_request_with_a_robot_accepts_a_tool(client) -> None:
    home = UR5.home.tolist()
    goal = (UR5.home + 0.1).tolist()
    for path, body in (
        ("/v1/trajectories/joint", {"robot": "ur5", "profile": "quintic",
                                    "start": {"positions": home}, "goal": {"positions": goal}}),
        ("/v1/trajectories/spline", {"robot": "ur5", "waypoints": [home, goal],
                                     "boundary": "clamped"}),
        ("/v1/robots/describe", {"robot": "ur5"}),
        ("/v1/distance", {"robot": "ur5", "positions": home}),
        ("/v1/robots/ur5/distance", {"positions": home}),
    ):  # fmt: skip
        response = client.post(path, json={**body, "tool": TOOL})
        assert response.status_code == 200, (path, response.text)


@pytest.mark.parametrize(
    ("tool", "loc"),
    [
        ({"position": [0, 0, 11.0], "orientation": [0, 0, 0, 1]}, ["body", "tool", "position", 2]),
        ({"position": [0, 0, 0.1], "orientation": [0, 0, 0.1, 1]}, ["body", "tool", "orientation"]),
        ({"position": [0, 0], "orientation": [0, 0, 0, 1]}, ["body", "tool", "position"]),
        ({"position": [0, 0, 0.1]}, ["body", "tool", "orientation"]),
    ],
)
def test_a_bad_tool_is_422_naming_the_field(client, tool: dict, loc: list) -> None:
    body = {"robot": "ur5", "positions": UR5.home.tolist(), "tool": tool}
    err = problem(client.post("/v1/fk", json=body), 422, "validation")
    assert err["errors"][0]["loc"] == loc
