"""A link and a joint sharing a name (issue 13, the SO-ARM100's ``gripper``): every frame lookup says
which kind of frame it means, and such a URDF works through robots/ and through the HTTP API.

The URDF below names its links and joints like the SO-ARM100 does where it matters: link ``wrist``
is moved by joint ``wrist``, link ``gripper`` by joint ``wrist_roll``, and joint ``gripper`` (the jaw)
moves link ``jaw``. With ``tip_frame="gripper"`` the jaw joint ``gripper`` is locked (the case that
answered 500); with ``tip_frame="jaw"`` it is on the chain.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from robots import registry
from service.app import create_app
from tests.robots.inline_urdfs import joint, robot

SHARED = robot(
    joint("shoulder_pan", "base", "shoulder", xyz="0 0 0.1", axis="0 0 1"),
    joint("shoulder_lift", "shoulder", "upper_arm", xyz="0.03 0 0.05", axis="0 1 0"),
    joint("elbow_flex", "upper_arm", "lower_arm", xyz="0.03 0 0.11", axis="0 1 0"),
    joint("wrist", "lower_arm", "wrist", xyz="0.13 0 0.01", axis="0 1 0"),
    joint("wrist_roll", "wrist", "gripper", xyz="0.05 0 0", axis="1 0 0"),
    joint("wrist_yaw", "gripper", "palm", xyz="0.02 0 0", axis="0 0 1"),
    joint("gripper", "palm", "jaw", xyz="0.04 0.01 0", axis="0 0 1"),
    joint("jaw_tip", "jaw", "jaw_tip", "fixed", xyz="0.03 0 0"),
    links=[
        "base",
        "shoulder",
        "upper_arm",
        "lower_arm",
        "wrist",
        "gripper",
        "palm",
        "jaw",
        "jaw_tip",
    ],
)
Q6 = np.array([0.3, -0.4, 0.7, 0.2, -0.5, 0.4])


def reference_fk(tip: str, q: np.ndarray) -> np.ndarray:
    """Independent reference: pinocchio on the full URDF (every joint movable; off-chain ones at 0),
    the tip looked up as a BODY frame."""
    full = pin.buildModelFromXML(SHARED)
    qf = np.zeros(full.nq)
    for name, value in zip(
        (
            "shoulder_pan",
            "shoulder_lift",
            "elbow_flex",
            "wrist",
            "wrist_roll",
            "wrist_yaw",
            "gripper",
        ),
        q,
        strict=False,
    ):
        qf[full.joints[full.getJointId(name)].idx_q] = value
    data = full.createData()
    pin.framesForwardKinematics(full, data, qf)
    return data.oMf[full.getFrameId(tip, pin.FrameType.BODY)].homogeneous


@pytest.mark.parametrize("tip", ["gripper", "palm", "jaw", "jaw_tip", "wrist"])
def test_fk_frames_and_jacobian_with_shared_names(tip: str) -> None:
    r = registry.load_inline(SHARED, tip, "base")
    q = np.concatenate([Q6, [0.25]])[: r.dof]
    np.testing.assert_allclose(r.fk(q), reference_fk(tip, q), atol=1e-12)
    np.testing.assert_allclose(r.fk_many(q[None])[0], r.fk(q), atol=1e-12)
    # the link frame "wrist" (not the joint frame of the same name) is what frame_pose gives
    np.testing.assert_allclose(r.frame_pose(q, "wrist"), reference_fk("wrist", q), atol=1e-12)
    assert r.frame_names().count("gripper") == 1


def test_locked_shared_name_joint_and_ik() -> None:
    r = registry.load_inline(SHARED, "palm", "base")
    assert r.joint_names == (
        "shoulder_pan",
        "shoulder_lift",
        "elbow_flex",
        "wrist",
        "wrist_roll",
        "wrist_yaw",
    )
    T = r.fk(Q6)
    result = r.ik(T, Q6 + 0.05)
    assert result.success
    np.testing.assert_allclose(r.fk(result.positions), T, atol=1e-6)


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app()) as c:
        yield c


def test_cartesian_plan_with_the_tip_on_a_shared_name(client: TestClient) -> None:
    inline = {"urdf": SHARED, "tip_frame": "palm", "base_frame": "base"}
    r = registry.load_inline(SHARED, "palm", "base")
    goal = Q6 + np.array([0.05, 0.04, -0.05, 0.03, 0.02, -0.04])
    body = {
        "robot": inline,
        "start": {"positions": Q6.tolist()},
        "goal": {"positions": goal.tolist()},
        "method": "sampled",
    }
    response = client.post("/v1/trajectories/cartesian", json=body)
    assert response.status_code == 200, response.text
    points = np.array([p["positions"] for p in response.json()["points"]])
    np.testing.assert_allclose(r.fk(points[-1]), r.fk(goal), atol=1e-6)
    # the tip on the link "jaw", moved by the joint "gripper" (sharing its name with a link)
    r7 = registry.load_inline(SHARED, "jaw", "base")
    q7, goal7 = np.append(Q6, 0.2), np.append(goal, 0.25)
    body["robot"] = {"urdf": SHARED, "tip_frame": "jaw", "base_frame": "base"}
    body["start"]["positions"], body["goal"]["positions"] = q7.tolist(), goal7.tolist()
    response = client.post("/v1/trajectories/cartesian", json=body)
    assert response.status_code == 200, response.text
    points = np.array([p["positions"] for p in response.json()["points"]])
    np.testing.assert_allclose(r7.fk(points[-1]), r7.fk(goal7), atol=1e-6)
