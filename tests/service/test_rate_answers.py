"""Resolved-rate answers a client should get (audit, second wave): a ball on the line is 422
``collision`` for ``resolved_rate_dls`` as for ``sampled`` (not a deviation blamed on the sampling);
the tool keeps ``max_linear_speed`` at every returned point; the PUMA 560's short line from home
slows the path clock instead of failing; the run ends on a whole control tick."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from robots import registry
from robots.geometry import ROBOT_GEOMETRY
from service.app import create_app
from service.schemas.common import Pose
from tests.service.helpers import problem

UR5 = registry.get("ur5")
PUMA = registry.get("puma560")
RATE_METHODS = ["resolved_rate", "resolved_rate_dls"]


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def tip(robot, q) -> np.ndarray:
    """The tool pose by pinocchio directly (not through the service's FK)."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return data.oMf[model.getFrameId(robot.tip_frame)].homogeneous.copy()


def lin(robot, offset, **extra) -> dict:
    T = robot.fk(robot.home)
    T[:3, 3] += offset
    return {
        "robot": extra.pop("name"),
        "start": {"positions": robot.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T).model_dump()},
        **extra,
    }


def point_segment(p, a, b) -> float:
    d = b - a
    t = float(np.clip((p - a) @ d / (d @ d), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * d)))


def tool_capsule_gap(q, center, radius) -> float:
    """Closed-form distance between the UR5's wrist_3_link capsule (placed by pinocchio) and a ball."""
    (c,) = [c for c in ROBOT_GEOMETRY["ur5"].capsules if c.link == "wrist_3_link"]
    T = UR5.frame_pose(np.asarray(q), "wrist_3_link")
    a, b = T[:3, :3] @ np.array(c.a) + T[:3, 3], T[:3, :3] @ np.array(c.b) + T[:3, 3]
    return point_segment(center, a, b) - c.radius - radius


OFFSET = np.array([0.0, 0.3, 0.0])
CENTER = UR5.fk(UR5.home)[:3, 3] + 0.7 * OFFSET
BALL = {
    "name": "ball",
    "shape": {"type": "sphere", "radius": 0.03},
    "pose": {"position": CENTER.tolist(), "orientation": [0.0, 0.0, 0.0, 1.0]},
}


def test_dls_with_a_ball_on_the_line_is_a_collision_where_sampled_says(client) -> None:
    """The UR5's 30 cm line runs through a 3 cm ball. ``sampled`` answers 422 collision at the s
    where the tool capsule first touches it; ``resolved_rate_dls`` keeps the clearance by leaving
    the line (5 cm), and answered 422 infeasible 'strays ... give more samples'. Now it gives the
    same answer: 422 collision, the same links, and an s within 1 % of the line of the closed-form
    first touch (the tool capsule translated along the line: the orientation is constant)."""
    env = {"obstacles": [BALL]}
    sampled = problem(
        client.post(
            "/v1/trajectories/cartesian",
            json=lin(UR5, OFFSET, name="ur5", method="sampled", environment=env),
        ),
        422,
        "collision",
    )
    dls = problem(
        client.post(
            "/v1/trajectories/cartesian",
            json=lin(UR5, OFFSET, name="ur5", method="resolved_rate_dls", environment=env),
        ),
        422,
        "collision",
    )
    assert dls["links"] == sampled["links"] == ["wrist_3_link", "ball"]
    # the tool translates along the line: the start's capsule moved by s * OFFSET
    (c,) = [c for c in ROBOT_GEOMETRY["ur5"].capsules if c.link == "wrist_3_link"]
    T = UR5.frame_pose(UR5.home, "wrist_3_link")
    a0, b0 = T[:3, :3] @ np.array(c.a) + T[:3, 3], T[:3, :3] @ np.array(c.b) + T[:3, 3]
    s = np.linspace(0.0, 1.0, 20_001)
    gaps = [point_segment(CENTER, a0 + x * OFFSET, b0 + x * OFFSET) - c.radius - 0.03 for x in s]
    s_star = float(s[int(np.argmax(np.array(gaps) <= 0.0))])
    assert dls["s"] == pytest.approx(s_star, abs=0.01)
    assert dls["s"] == pytest.approx(sampled["s"], abs=0.01)
    assert dls["distance"] <= 1e-6 and 0.0 < dls["time_from_start"]
    assert "give more samples" not in dls["detail"]


def test_dls_partial_with_a_ball_returns_the_clear_prefix_on_the_line(client) -> None:
    """With ``allow_partial``: 200, ``diagnostics.failure`` the collision, the prefix ends before
    it (``fraction`` <= its s), every returned point clear of the ball (closed form) and on the
    line within the tolerance (pinocchio FK against the segment)."""
    body = lin(
        UR5,
        OFFSET,
        name="ur5",
        method="resolved_rate_dls",
        environment={"obstacles": [BALL]},
        allow_partial=True,
    )
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    failure = doc["diagnostics"]["failure"]
    assert failure["code"] == "collision" and failure["links"] == ["wrist_3_link", "ball"]
    assert failure["s"] - 0.05 < doc["diagnostics"]["fraction"] <= failure["s"]
    qs = np.array([p["positions"] for p in doc["points"]])
    assert min(tool_capsule_gap(q, CENTER, 0.03) for q in qs) >= 0.0
    p0 = UR5.fk(UR5.home)[:3, 3]
    assert max(point_segment(tip(UR5, q)[:3, 3], p0, p0 + OFFSET) for q in qs) <= 1e-3


@pytest.mark.parametrize("method", RATE_METHODS)
def test_rate_methods_keep_max_linear_speed(client: TestClient, method: str) -> None:
    """The tool's own speed (central differences of pinocchio FK along each returned point's
    velocity) stays within ``max_linear_speed`` (the 200 rule's relative slack 1e-6) and reaches it:
    the controllers' feedback term pushed it to 0.0503 m/s for 0.05."""
    T = UR5.fk(UR5.home)
    T[:3, 3] += [0.2, 0.1, -0.1]
    body = {
        "robot": "ur5",
        "method": method,
        "start": {"positions": UR5.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T).model_dump()},
        "max_linear_speed": 0.05,
    }
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    h, speeds = 1e-6, []
    for p in answer.json()["points"]:
        q, qd = np.asarray(p["positions"]), np.asarray(p["velocities"])
        speeds.append(np.linalg.norm(tip(UR5, q + h * qd)[:3, 3] - tip(UR5, q - h * qd)[:3, 3]))
    top = max(speeds) / (2 * h)
    assert 0.05 * 0.99 <= top <= 0.05 * (1 + 1e-6)


@pytest.mark.parametrize("method", RATE_METHODS)
@pytest.mark.parametrize("period", [0.001, 0.002, 0.005])
def test_the_run_ends_on_a_whole_control_tick(
    client: TestClient, method: str, period: float
) -> None:
    """A 20 cm line at the default 0.25 m/s: the profile lasts 1.0500001601 s (its grid), and the
    controller stretched its tick to 0.99905 ms to end there, 1.6e-7 s past the last 10 ms sample.
    Now it ticks at the requested ``control_period`` (reported as such) and the trajectory ends on
    a whole tick at or after the profile's end, so every interval of the 10 ms grid is a whole
    number of ticks (a period dividing 10 ms): the last one too."""
    body = lin(UR5, [0.2, 0.0, 0.0], name="ur5", method=method, control_period=period)
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    t = np.array([p["time_from_start"] for p in doc["points"]])
    diag = doc["diagnostics"]
    assert diag["control_period"] == period
    ticks = t[-1] / period
    assert ticks == pytest.approx(round(ticks), abs=1e-9)
    assert diag["nominal_duration"] <= t[-1]
    gaps = np.diff(t)
    assert gaps[-1] >= period - 1e-12
    np.testing.assert_allclose(gaps / period, np.round(gaps / period), rtol=0, atol=1e-9)


@pytest.mark.parametrize("method", RATE_METHODS)
@pytest.mark.parametrize("dx", [0.07, -0.07])
def test_puma_short_line_slows_for_joint_accelerations(
    client: TestClient, method: str, dx: float
) -> None:
    """The PUMA 560's 7 cm line along x from home at the default tool limits: the nominal clock asks
    joint 3 for 1.7-1.8 times its 2 rad/s^2 (was 422 joint_rate_limit; the DLS time scaling holds
    velocities only). Now the clock slows as ``sampled`` does: 200, every joint within its
    velocity and acceleration limits (central differences of the returned velocities), the tool on
    the line (pinocchio FK), at the goal, and about as long as ``sampled``'s timing of the line."""
    body = lin(PUMA, [dx, 0.0, 0.0], name="puma560", method=method)
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    points = answer.json()["points"]
    t = np.array([p["time_from_start"] for p in points])
    q = np.array([p["positions"] for p in points])
    v = np.array([p["velocities"] for p in points])
    assert np.all(np.abs(v) <= PUMA.velocity_limits * (1 + 1e-6))
    acc = np.abs(np.gradient(v, t, axis=0)) / np.asarray(PUMA.acceleration_limits)
    assert acc.max() <= 1 + 1e-6
    assert acc.max() >= 0.5  # and the limits are what shapes it
    p0 = PUMA.fk(PUMA.home)[:3, 3]
    p1 = p0 + np.array([dx, 0.0, 0.0])
    assert max(point_segment(tip(PUMA, x)[:3, 3], p0, p1) for x in q) <= 1e-3
    np.testing.assert_allclose(tip(PUMA, q[-1])[:3, 3], p1, atol=1e-4)
    sampled = client.post("/v1/trajectories/cartesian", json={**body, "method": "sampled"})
    assert sampled.status_code == 200
    assert t[-1] == pytest.approx(sampled.json()["points"][-1]["time_from_start"], rel=0.05)


@pytest.mark.parametrize("method", RATE_METHODS)
def test_rate_methods_keep_max_angular_speed(client: TestClient, method: str) -> None:
    """The same for the tool's angular speed (the rotation between pinocchio FK poses a step
    before and after each returned point): 0.2007 rad/s for a 0.2 rad/s limit before."""
    T = UR5.fk(UR5.home)
    T[:3, 3] += [0.05, 0.0, 0.0]
    T[:3, :3] = Rotation.from_rotvec([0.2, 0.3, -0.3]).as_matrix() @ T[:3, :3]
    body = {
        "robot": "ur5",
        "method": method,
        "start": {"positions": UR5.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T).model_dump()},
        "max_angular_speed": 0.2,
    }
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    h, speeds = 1e-6, []
    for p in answer.json()["points"]:
        q, qd = np.asarray(p["positions"]), np.asarray(p["velocities"])
        A, B = tip(UR5, q + h * qd)[:3, :3], tip(UR5, q - h * qd)[:3, :3]
        speeds.append(np.linalg.norm(Rotation.from_matrix(A @ B.T).as_rotvec()) / (2 * h))
    assert 0.2 * 0.99 <= max(speeds) <= 0.2 * (1 + 1e-6)


WRIST = {
    "robot": "puma560",
    "method": "resolved_rate_dls",
    "start": {"positions": [0.0, 0.6, -2.6, 0.0, 0.25, 0.0]},
    "goal": {"positions": [0.0, 0.6, -2.6, 0.0, -0.25, 0.0]},
}
"""A PUMA 560 line on which q5 goes from +0.25 to -0.25 rad: through the wrist singularity."""


def test_keep_configuration_false_lets_the_dls_pass_the_wrist_singularity(client) -> None:
    """Issue 25 item 11: the line through the PUMA's wrist singularity is 422 branch_flip by
    default (unchanged); with keep_configuration false a 200 whose configuration_changes names
    the change (the wrist label is the sign of q5: checked on the returned positions), the tool on
    the line within the tolerance (pinocchio FK), every joint within its velocity limit and, by
    second differences of the returned positions, its acceleration limit."""
    problem(client.post("/v1/trajectories/cartesian", json=WRIST), 422, "branch_flip")
    answer = client.post("/v1/trajectories/cartesian", json={**WRIST, "keep_configuration": False})
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    t = np.array([p["time_from_start"] for p in doc["points"]])
    q = np.array([p["positions"] for p in doc["points"]])
    v = np.array([p["velocities"] for p in doc["points"]])
    (change,) = doc["diagnostics"]["configuration_changes"]
    assert change["from"].endswith("-flip") and change["to"].endswith("-noflip")
    assert change["from"].rsplit("-", 1)[0] == change["to"].rsplit("-", 1)[0]
    flips = np.flatnonzero(np.diff(np.sign(q[:, 4])) != 0)
    assert len(flips) == 1 and q[0, 4] > 0 > q[-1, 4]
    T0, T1 = tip(PUMA, q[0]), tip(PUMA, WRIST["goal"]["positions"])
    p0, p1 = T0[:3, 3], T1[:3, 3]

    def turned(T: np.ndarray) -> float:  # rotation angle from the start [rad]
        return float(Rotation.from_matrix(T0[:3, :3].T @ T[:3, :3]).magnitude())

    # the line turns the tool about a fixed axis: s is the share of the angle turned
    s_tool = [turned(tip(PUMA, x)) / turned(T1) for x in q]
    i = flips[0]  # the sign of q5 changes between returned points i and i + 1
    assert s_tool[i] - 1e-3 <= change["s"] <= s_tool[i + 1] + 1e-3
    np.testing.assert_allclose(p0, p1, atol=1e-12)  # (the tip frame is the wrist centre)
    assert max(np.linalg.norm(tip(PUMA, x)[:3, 3] - p0) for x in q) <= 1e-3
    axis = Rotation.from_matrix(T0[:3, :3].T @ T1[:3, :3]).as_rotvec()
    for x, share in zip(q, s_tool, strict=True):  # on the slerp within the tolerance
        R_line = T0[:3, :3] @ Rotation.from_rotvec(share * axis).as_matrix()
        assert Rotation.from_matrix(R_line.T @ tip(PUMA, x)[:3, :3]).magnitude() <= 1e-2
    assert np.all(np.abs(v) <= PUMA.velocity_limits * (1 + 1e-9))
    h = np.diff(t)
    same = np.flatnonzero(np.abs(h[:-1] - h[1:]) < 1e-12)
    d2 = (q[same + 2] - 2 * q[same + 1] + q[same]) / h[same, None] ** 2
    assert np.all(np.abs(d2) <= np.asarray(PUMA.acceleration_limits) * (1 + 1e-6))
    # the other methods follow one IK branch either way: the same answer as by default
    for method in ("sampled", "bounded_deviation"):
        body = {**WRIST, "method": method}
        default = client.post("/v1/trajectories/cartesian", json=body)
        free = client.post("/v1/trajectories/cartesian", json={**body, "keep_configuration": False})
        assert free.status_code == default.status_code
        assert free.json().get("code") == default.json().get("code")
