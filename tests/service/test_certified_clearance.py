"""``min_clearance`` is certified between the returned points (API.md "Clearance is certified"):
checked with coal directly on a fine sweep of the returned motion (joints linear between the
returned points), never with the service's own engine."""

from __future__ import annotations

import coal
import numpy as np
import pytest
from fastapi.testclient import TestClient

from robots import registry
from robots.geometry import ROBOT_GEOMETRY
from service.app import create_app
from service.schemas.common import Pose
from tests.service.helpers import problem

UR5 = registry.get("ur5")
HOME = UR5.home
CLEARANCE = 0.02


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def coal_min(qs: np.ndarray, center: np.ndarray, radius: float) -> float:
    """Smallest coal distance from every moving UR5 capsule to the ball, over the rows of ``qs``."""
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    ball = coal.Sphere(radius)
    at = coal.Transform3s(np.eye(3), center)
    out = np.inf
    for q in qs:
        for c in ROBOT_GEOMETRY["ur5"].capsules:
            if c.link == "base_link":
                continue  # stands on its mount: never checked against obstacles
            T = UR5.frame_pose(q, c.link)
            a = T[:3, :3] @ np.array(c.a) + T[:3, 3]
            b = T[:3, :3] @ np.array(c.b) + T[:3, 3]
            length = float(np.linalg.norm(b - a))
            shape = coal.Capsule(c.radius, length) if length > 0 else coal.Sphere(c.radius)
            z = (b - a) / length if length > 0 else np.array([0.0, 0.0, 1.0])
            x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
            x /= np.linalg.norm(x)
            R = np.column_stack([x, np.cross(z, x), z])
            res.clear()
            out = min(
                out, coal.distance(shape, coal.Transform3s(R, (a + b) / 2), ball, at, req, res)
            )
    return float(out)


def sweep(qs: np.ndarray, per_segment: int) -> np.ndarray:
    """The returned motion sampled ``per_segment`` times per segment, joints linear, ends included."""
    f = np.linspace(0, 1, per_segment + 1)[:-1]
    steps = np.diff(qs, axis=0)
    return np.vstack(
        [(qs[:-1, None] + f[:, None] * steps[:, None]).reshape(-1, qs.shape[1]), qs[-1:]]
    )


def joint_move(center: np.ndarray, radius: float) -> dict:
    goal = HOME + np.array([0.6, 0.0, 0.0, 0.0, 0.0, 0.0])
    ball = {"name": "ball", "shape": {"type": "sphere", "radius": radius},
            "pose": {"position": center.tolist(), "orientation": [0, 0, 0, 1]}}  # fmt: skip
    return {
        "robot": "ur5",
        "start": {"positions": HOME.tolist()},
        "goal": {"positions": goal.tolist()},
        "profile": "quintic",
        "samples": 8,
        "environment": {"obstacles": [ball], "clearance": CLEARANCE, "self_collision": False},
    }


def test_eight_samples_beside_a_ball_between_the_points(client) -> None:
    """A joint move of 8 samples passing a ball: the closest approach lies between two returned
    points. With the ball where coal's sweep comes to 4 um inside the clearance while every returned
    point keeps it (the answer was a 200 with min_clearance 0.020225 m), it is 422 collision; 0.1 mm
    farther out, a 200 whose min_clearance is at most the sweep's minimum and within 1e-4 m of it."""
    probe = {**joint_move(np.zeros(3), 0.05), "environment": None}
    points = client.post("/v1/trajectories/joint", json=probe).json()["points"]
    qs = np.array([p["positions"] for p in points])
    times = np.array([p["time_from_start"] for p in points])
    widest = int(np.argmax(np.abs(np.diff(qs[:, 0]))))
    inside = qs[widest] + 0.3 * (qs[widest + 1] - qs[widest])  # the ball beside the tool there
    tool = UR5.fk(inside)[:3, 3]
    out = tool * np.array([1.0, 1.0, 0.0])  # away from the base's axis
    center = tool + 0.15 * out / np.linalg.norm(out)  # 15 cm out
    dense = sweep(qs, 400)
    r0 = 0.05
    gap = coal_min(dense, center, r0) - (CLEARANCE - 4e-6)
    radius = r0 + gap  # the ball grown until the sweep's minimum is 4 um inside the clearance
    assert coal_min(dense, center, radius) == pytest.approx(CLEARANCE - 4e-6, abs=1e-9)
    assert coal_min(qs, center, radius) >= CLEARANCE  # every returned point keeps the clearance
    err = problem(
        client.post("/v1/trajectories/joint", json=joint_move(center, radius)), 422, "collision"
    )
    assert err["links"][1] == "ball"
    assert times[widest] < err["time_from_start"] < times[widest + 1]  # between the two points
    clear = radius - 1e-4
    doc = client.post("/v1/trajectories/joint", json=joint_move(center, clear)).json()
    true_min = coal_min(
        sweep(np.array([p["positions"] for p in doc["points"]]), 400), center, clear
    )
    reported = doc["diagnostics"]["min_clearance"]
    assert CLEARANCE <= reported <= true_min + 1e-9
    assert reported >= true_min - 1e-4


def test_a_sampled_line_past_a_ball_reports_a_certified_minimum(client) -> None:
    """A sampled Cartesian line past a ball (it reported the minimum at its returned points, 1.5e-6 m
    above the motion's): min_clearance is a lower bound of coal's sweep between the points, within
    1e-4 m."""
    T1 = UR5.fk(HOME)
    T1[:3, 3] += [0.0, 0.25, -0.05]
    center = (UR5.fk(HOME)[:3, 3] + T1[:3, 3]) / 2 + [0.0, 0.0, -0.13]
    body = {
        "robot": "ur5",
        "start": {"positions": HOME.tolist()},
        "goal": {"pose": Pose.from_matrix(T1).model_dump()},
        "method": "sampled",
        "samples": 40,
        "environment": {"obstacles": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.03},
                        "pose": {"position": center.tolist(), "orientation": [0, 0, 0, 1]}}],
                        "self_collision": False},
    }  # fmt: skip
    doc = client.post("/v1/trajectories/cartesian", json=body).json()
    qs = np.array([p["positions"] for p in doc["points"]])
    true_min = coal_min(sweep(qs, 50), center, 0.03)
    reported = doc["diagnostics"]["min_clearance"]
    assert true_min - 1e-4 <= reported <= true_min + 1e-9
    assert coal_min(qs, center, 0.03) >= true_min  # the points alone see no less
