"""Every endpoint on real robot descriptions from other projects (tests/fixtures/urdf/, sources and
licences in its README), sent inline as their authors wrote them.

References: pinocchio's own model of the untouched URDF text (FK, frames and Jacobian to 1e-9), the
service's FK of its own IK answers, closed forms (rest-to-rest ends, straight lines). The fast tests
run a compact sweep; ``test_every_endpoint_never_fails_badly`` (slow) runs every method with and
without an environment and checks only what must always hold (no 5xx, finite numbers, 422s that
name their code and field).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from core.geometry.so3 import quat_to_matrix

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "urdf"

ARMS: dict[str, tuple[str, str, str, list[float]]] = {
    # name: (file, base_frame, tip_frame, a start inside the limits, away from singularities)
    "ur5": ("ur5_robot.urdf", "base_link", "tool0", [0.22, -0.17, -0.4, -0.26, 0.11, 0.38]),
    "panda_hand": (
        "panda.urdf",
        "panda_link0",
        "panda_hand",
        [0.4, 0.22, -0.17, -1.97, -0.26, 1.68, 0.38],
    ),
    "jaco2": (
        "kinova_j2s6s200.urdf",
        "base",
        "j2s6s200_end_effector",
        [0.4, 2.2, 1.57, -0.4, 1.57, 0.11],
    ),
    "z1": ("z1.urdf", "world", "gripperStator", [0.4, 1.7, -1.6, -0.4, -0.26, 0.11]),
    "talos_arm": (
        "talos_left_arm.urdf",
        "arm_left_1_link",
        "gripper_left_base_link",
        [1.66, -0.17, -1.57, -0.26, 0.11, 0.38],
    ),
    "so100": ("so100.urdf", "base", "jaw", [0.11, 1.96, -1.27, -0.71, -0.36, 0.56]),
    "iiwa": (
        "kuka_iiwa.urdf",
        "lbr_iiwa_link_0",
        "lbr_iiwa_link_7",
        [-0.4, -0.26, 0.11, 0.38, 0.3, -0.06, -0.36],
    ),
}


def inline(name: str) -> dict[str, str]:
    file, base, tip, _ = ARMS[name]
    return {
        "urdf": (FIXTURES / file).read_text(encoding="utf-8"),
        "base_frame": base,
        "tip_frame": tip,
    }


def ok(client: TestClient, url: str, body: dict[str, Any]) -> dict[str, Any]:
    r = client.post(url, json=body)
    assert r.status_code == 200, f"{url}: {r.text[:400]}"
    return r.json()


def reference_model(urdf: str) -> tuple[pin.Model, pin.Data]:
    model = pin.buildModelFromXML(urdf)
    return model, model.createData()


def reference_q(model: pin.Model, names: list[str], q: np.ndarray) -> np.ndarray:
    """pinocchio's configuration for the chain joints at ``q`` (every other joint at neutral)."""
    qf = pin.neutral(model)
    for name, value in zip(names, q, strict=True):
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 2:  # continuous: (cos, sin)
            qf[joint.idx_q : joint.idx_q + 2] = [math.cos(value), math.sin(value)]
        else:
            qf[joint.idx_q] = value
    return qf


def body_frame(model: pin.Model, link: str) -> int:
    return model.getFrameId(link, pin.FrameType.BODY)


def pose_matrix(pose: dict[str, list[float]]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(np.array(pose["orientation"]))
    T[:3, 3] = pose["position"]
    return T


@pytest.mark.parametrize("name", list(ARMS))
def test_fk_frames_and_jacobian_equal_pinocchio(client: TestClient, name: str) -> None:
    robot = inline(name)
    d = ok(client, "/v1/robots/describe", {"robot": robot})
    model, data = reference_model(robot["urdf"])
    # the joints are the movable ones on the root -> tip path, root first
    path = [
        model.names[j]
        for j in model.supports[model.frames[body_frame(model, robot["tip_frame"])].parentJoint]
    ]
    assert d["joint_names"] == [n for n in path if n != "universe"]
    for q in (np.array(d["home"]), np.array(ARMS[name][3])):
        a = ok(client, "/v1/fk", {"robot": robot, "positions": q.tolist(), "frames": True})
        qf = reference_q(model, d["joint_names"], q)
        pin.framesForwardKinematics(model, data, qf)
        base = data.oMf[body_frame(model, robot["base_frame"])]
        tip = base.actInv(data.oMf[body_frame(model, robot["tip_frame"])])
        np.testing.assert_allclose(pose_matrix(a["pose"]), tip.homogeneous, atol=1e-9)
        assert a["frames"], "frames: true lists the link frames"
        for frame in a["frames"]:
            expected = base.actInv(data.oMf[body_frame(model, frame["name"])]).homogeneous
            np.testing.assert_allclose(pose_matrix(frame), expected, atol=1e-9)
        J = pin.computeFrameJacobian(
            model, data, qf, body_frame(model, robot["tip_frame"]), pin.LOCAL_WORLD_ALIGNED
        )
        cols = [model.joints[model.getJointId(n)].idx_v for n in d["joint_names"]]
        R = base.rotation.T
        expected_J = np.vstack([R @ J[:3, cols], R @ J[3:, cols]])
        np.testing.assert_allclose(np.array(a["jacobian"]), expected_J, atol=1e-9)


@pytest.mark.parametrize("name", list(ARMS))
def test_ik_all_reproduces_the_pose_with_distinct_labels(client: TestClient, name: str) -> None:
    robot, q = inline(name), np.array(ARMS[name][3])
    d = ok(client, "/v1/robots/describe", {"robot": robot})
    pose = ok(client, "/v1/fk", {"robot": robot, "positions": q.tolist()})["pose"]
    body: dict[str, Any] = {"robot": robot, "pose": pose, "all": True, "seed": q.tolist()}
    fixed = {n: float(q[d["joint_names"].index(n)]) for n in d["ik"]["redundant_joints"]}
    if fixed:
        body["fixed_joints"] = fixed
    answer = ok(client, "/v1/ik", body)
    assert answer["solver"] == d["ik"]["solver"]
    solutions = answer["solutions"]
    lo, hi = np.array(d["limits"]["position"]).T
    for s in solutions:
        qs = np.array(s["positions"])
        assert np.all(qs >= lo - 1e-12) and np.all(qs <= hi + 1e-12)
        again = ok(client, "/v1/fk", {"robot": robot, "positions": s["positions"]})
        np.testing.assert_allclose(pose_matrix(again["pose"]), pose_matrix(pose), atol=1e-8)
        assert again["configuration"] == s["configuration"]
        for joint, value in fixed.items():
            assert qs[d["joint_names"].index(joint)] == pytest.approx(value, abs=1e-12)
    labels = [s["configuration"] for s in solutions if s["configuration"] is not None]
    assert len(set(labels)) == len(labels)
    # the configuration the pose came from is among them, nearest the seed: first
    np.testing.assert_allclose(solutions[0]["positions"], q, atol=1e-7)
    if labels:
        assert set(labels) <= set(d["configurations"])
        one = ok(client, "/v1/ik", {**body, "all": False, "configuration": labels[-1]})
        assert one["configuration"] == labels[-1]


@pytest.mark.parametrize("name", list(ARMS))
def test_trajectories_programs_and_distances(client: TestClient, name: str) -> None:
    robot, q0 = inline(name), np.array(ARMS[name][3])
    d = ok(client, "/v1/robots/describe", {"robot": robot})
    n = d["dof"]
    lo, hi = np.array(d["limits"]["position"]).T
    q1 = np.clip(q0 + 0.2 * np.cos(np.arange(n)), lo, hi)
    for profile in ("quintic", "trapezoidal", "jerk_limited"):
        body: dict[str, Any] = {
            "robot": robot,
            "profile": profile,
            "start": {"positions": q0.tolist()},
            "goal": {"positions": q1.tolist()},
            "environment": {"self_collision": False},
        }
        if profile == "jerk_limited":
            body["limits"] = {"jerk": [200.0] * n}
        points = ok(client, "/v1/trajectories/joint", body)["points"]
        np.testing.assert_allclose(points[0]["positions"], q0, atol=1e-12)
        np.testing.assert_allclose(points[-1]["positions"], q1, atol=1e-9)
        np.testing.assert_allclose(points[-1]["velocities"], 0.0, atol=1e-9)
    T0 = pose_matrix(ok(client, "/v1/fk", {"robot": robot, "positions": q0.tolist()})["pose"])
    goal = {
        "position": (T0[:3, 3] + [0.0, 0.0, 0.01]).tolist(),
        "orientation": ok(client, "/v1/fk", {"robot": robot, "positions": q0.tolist()})["pose"][
            "orientation"
        ],
    }
    task = {
        "robot": robot,
        "start": {"positions": q0.tolist()},
        "goal": {"pose": goal},
        "max_linear_speed": 0.1,
        "max_angular_speed": 0.5,
        "environment": {"self_collision": False},
    }
    for method in ("sampled", "bounded_deviation"):
        plan = ok(client, "/v1/trajectories/cartesian", {**task, "method": method})
        assert plan["diagnostics"]["max_position_deviation"] <= 1e-3
        end = ok(client, "/v1/fk", {"robot": robot, "positions": plan["points"][-1]["positions"]})
        np.testing.assert_allclose(end["pose"]["position"], goal["position"], atol=1e-6)
    program = ok(
        client,
        "/v1/trajectories/program",
        {
            "robot": robot,
            "start": {"positions": q0.tolist()},
            "environment": {"self_collision": False},
            "segments": [
                {"type": "ptp", "goal": {"positions": q1.tolist()}},
                {"type": "ptp", "goal": {"positions": q0.tolist()}},
                {"type": "lin", "goal": {"pose": goal}, "max_linear_speed": 0.1},
            ],
        },
    )
    assert [s["type"] for s in program["segments"]] == ["ptp", "ptp", "lin"]
    ball = {
        "name": "ball",
        "shape": {"type": "sphere", "radius": 0.05},
        "pose": {"position": (T0[:3, 3] + [0.3, 0.0, 0.0]).tolist(), "orientation": [0, 0, 0, 1]},
    }
    dist = ok(
        client,
        "/v1/distance",
        {"robot": robot, "positions": q0.tolist(), "environment": {"obstacles": [ball]}},
    )
    if d["collision_geometry"]:
        assert math.isfinite(dist["min_distance"])
        assert [p["distance"] for p in dist["pairs"]] == sorted(
            p["distance"] for p in dist["pairs"]
        )


@pytest.mark.parametrize(
    "robot",
    [
        "planar_2r",
        {
            "urdf": (FIXTURES / "two_joint_robot.urdf").read_text(encoding="utf-8"),
            "base_frame": "base_link",
            "tip_frame": "link_23_cyl",
        },
    ],
    ids=["shipped", "inline"],
)
def test_program_lin_that_moves_only_outside_the_planar_task_space(
    client: TestClient, robot: Any
) -> None:
    # A LIN whose goal differs from its start only in z (or orientation) moves a planar arm
    # (task space x-y) nowhere: it was planned as a motion, never timed, and the report raised
    # KeyError (HTTP 500). It is a zero-length segment: skipped, with a warning.
    q = [0.3, 1.0]
    pose = ok(client, "/v1/fk", {"robot": robot, "positions": q})["pose"]
    up = {"position": [*pose["position"][:2], 0.02], "orientation": [0.0, 0.0, 0.6, 0.8]}
    cases = (
        (
            [
                {"type": "lin", "goal": {"pose": up}},
                {"type": "ptp", "goal": {"positions": [0.5, 1.2]}},
            ],
            [0.5, 1.2],
        ),
        (
            [
                {"type": "ptp", "goal": {"positions": [0.5, 1.2]}},
                {"type": "ptp", "goal": {"positions": q}},
                {"type": "lin", "goal": {"pose": up}},
            ],
            q,
        ),
    )
    for segments, end in cases:
        body = {"robot": robot, "start": {"positions": q}, "segments": segments}
        answer = ok(client, "/v1/trajectories/program", body)
        for lin in (s for s in answer["segments"] if s["type"] == "lin"):
            assert lin["start_time"] == lin["end_time"] and lin["diagnostics"]["skipped"]
        assert any("zero length" in w for w in answer["diagnostics"]["warnings"])
        np.testing.assert_allclose(answer["points"][-1]["positions"], end, atol=1e-9)
    alone = {
        "robot": robot,
        "start": {"positions": q},
        "segments": [{"type": "lin", "goal": {"pose": up}}],
    }
    # issue 25.4: a program that moves no joint is 200 at rest with a warning (was 422)
    answer = ok(client, "/v1/trajectories/program", alone)
    assert all(p["positions"] == q for p in answer["points"])
    assert any("zero length" in w for w in answer["diagnostics"]["warnings"])


def test_describe_real_urdfs_that_were_refused_or_failed(client: TestClient) -> None:
    # example-robot-data's quadruped: revolute limits without lower/upper (0 by the URDF spec)
    quadruped = (FIXTURES / "quadruped.urdf").read_text(encoding="utf-8")
    d = ok(
        client,
        "/v1/robots/describe",
        {"robot": {"urdf": quadruped, "base_frame": "base_link", "tip_frame": "FL_contact"}},
    )
    assert d["joint_names"] == ["FL_HFE", "FL_KFE"]
    assert d["limits"]["position"] == [[-10.0, 10.0], [0.0, 0.0]]
    # two Pandas with hands: 89 collision primitives were over the bound of 64 (422 too_large for
    # every trajectory, even with self_collision false)
    dual = {
        "urdf": (FIXTURES / "dual_panda.urdf").read_text(encoding="utf-8"),
        "base_frame": "panda_1_link0",
        "tip_frame": "panda_1_hand",
    }
    d = ok(client, "/v1/robots/describe", {"robot": dual})
    assert len(d["collision_geometry"]) == 89 and d["dof"] == 7
    q0 = [0.0, -0.5, 0.0, -2.0, 0.0, 1.5, 0.7]
    plan = ok(
        client,
        "/v1/trajectories/joint",
        {
            "robot": dual,
            "profile": "quintic",
            "start": {"positions": q0},
            "goal": {"positions": [0.3, *q0[1:]]},
        },
    )
    assert plan["diagnostics"]["min_clearance"] > 0.0
    # the SO-ARM100: a link and a joint both named "gripper" (the jaw's joint)
    d = ok(client, "/v1/robots/describe", {"robot": inline("so100")})
    assert d["joint_names"][-1] == "gripper" and "gripper" in [
        f["name"]
        for f in ok(
            client, "/v1/fk", {"robot": inline("so100"), "positions": d["home"], "frames": True}
        )["frames"]
    ]


def frameless(file: str) -> dict[str, str]:
    """An inline robot without tip_frame and base_frame: the service picks them."""
    return {"urdf": (FIXTURES / file).read_text(encoding="utf-8")}


@pytest.mark.parametrize(
    ("file", "base", "tip", "q"),
    [
        # tool0 and ee_link are both fixed to wrist_3_link: tool0 (REP 199's tool frame)
        ("ur5_robot.urdf", "world", "tool0", ARMS["ur5"][3]),
        ("two_joint_robot.urdf", "base_link", "link_23_cyl", [0.3, 1.0]),  # planar
        ("double_pendulum_continuous.urdf", "base_link", "link2", [0.3, -2.0]),
        ("kortex_gen3_lite.urdf", "BASE", "DUMMY", [0.4, 0.3, 1.9, -0.4, 1.57, 0.11]),
    ],
    ids=["ur5", "planar", "pendulum", "gen3_lite"],
)
def test_default_frames_are_the_root_and_the_end_of_the_chain(
    client: TestClient, file: str, base: str, tip: str, q: list[float]
) -> None:
    robot = frameless(file)
    d = ok(client, "/v1/robots/describe", {"robot": robot})
    assert (d["base_frame"], d["tip_frame"]) == (base, tip)
    named = {**robot, "base_frame": base, "tip_frame": tip}
    assert ok(client, "/v1/robots/describe", {"robot": named})["name"] == d["name"]
    # FK of the frameless robot: pinocchio's tip in its base, from the untouched URDF
    model, data = reference_model(robot["urdf"])
    pin.framesForwardKinematics(model, data, reference_q(model, d["joint_names"], np.array(q)))
    expected = data.oMf[body_frame(model, base)].actInv(data.oMf[body_frame(model, tip)])
    fk = ok(client, "/v1/fk", {"robot": robot, "positions": q})
    T = pose_matrix(fk["pose"])
    if d["task_space"] == "pose":
        np.testing.assert_allclose(T, expected.homogeneous, atol=1e-9)
    else:
        np.testing.assert_allclose(T[:2, 3], expected.translation[:2], atol=1e-9)
    # IK, trajectories, program and distance take it too
    one = ok(client, "/v1/ik", {"robot": robot, "pose": fk["pose"], "seed": q})
    again = ok(client, "/v1/fk", {"robot": robot, "positions": one["positions"]})
    np.testing.assert_allclose(again["pose"]["position"], fk["pose"]["position"], atol=1e-8)
    lo, hi = np.array(d["limits"]["position"]).T
    q1 = np.clip(np.array(q) + 0.1, lo, hi).tolist()
    start, goal = {"positions": q}, {"positions": q1}
    plan = ok(
        client,
        "/v1/trajectories/joint",
        {"robot": robot, "profile": "quintic", "start": start, "goal": goal},
    )
    np.testing.assert_allclose(plan["points"][-1]["positions"], q1, atol=1e-9)
    segments = [{"type": "ptp", "goal": goal}, {"type": "ptp", "goal": start}]
    program = {"robot": robot, "start": start, "segments": segments}
    np.testing.assert_allclose(
        ok(client, "/v1/trajectories/program", program)["points"][-1]["positions"], q, atol=1e-9
    )
    assert "pairs" in ok(client, "/v1/distance", {"robot": robot, "positions": q})


def test_a_hand_with_fingers_has_no_default_tip_at_any_endpoint(client: TestClient) -> None:
    panda = frameless("panda.urdf")
    q = ARMS["panda_hand"][3]
    tcp = {"position": [0.4, 0.0, 0.4], "orientation": [1.0, 0.0, 0.0, 0.0]}
    task = {"robot": panda, "start": {"positions": q}, "goal": {"pose": tcp}}
    for url, body in (
        ("/v1/robots/describe", {"robot": panda}),
        ("/v1/fk", {"robot": panda, "positions": q}),
        ("/v1/ik", {"robot": panda, "pose": tcp}),
        ("/v1/distance", {"robot": panda, "positions": q}),
        (
            "/v1/trajectories/joint",
            {
                "robot": panda,
                "profile": "quintic",
                "start": {"positions": q},
                "goal": {"positions": q},
            },
        ),
        ("/v1/trajectories/cartesian", {**task, "method": "sampled"}),
        ("/v1/compare", {"task": task, "methods": ["sampled"]}),
    ):
        r = client.post(url, json=body)
        assert r.status_code == 422, f"{url}: {r.text[:300]}"
        problem = r.json()
        assert problem["code"] == "invalid_urdf", f"{url}: {problem}"
        assert problem["errors"][0]["loc"][-2:] == ["robot", "tip_frame"], url
        assert {"panda_leftfinger", "panda_rightfinger"} <= set(problem["candidates"])
        assert "panda_leftfinger" in problem["detail"] and "name tip_frame" in problem["detail"]
    # naming the tip (and leaving the base out) works: the base is the root, panda_link0
    d = ok(client, "/v1/robots/describe", {"robot": {**panda, "tip_frame": "panda_hand"}})
    assert d["base_frame"] == "panda_link0" and d["dof"] == 7


def test_one_ik_solution_of_a_numeric_8_joint_arm_from_home(client: TestClient) -> None:
    # the Panda to its left finger (7 revolute joints and the prismatic finger: numeric IK, joint 7
    # and the finger held at home's values at first): reachable poses the first search misses
    robot = {**inline("panda_hand"), "tip_frame": "panda_leftfinger"}
    d = ok(client, "/v1/robots/describe", {"robot": robot})
    assert d["ik"]["solver"] == "numeric" and d["dof"] == 8
    lo, hi = np.array(d["limits"]["position"]).T
    model, data = reference_model(robot["urdf"])
    base, tip = body_frame(model, "panda_link0"), body_frame(model, "panda_leftfinger")
    missed = 0
    for q in np.random.default_rng(2).uniform(lo, hi, (6, 8)):
        pose = ok(client, "/v1/fk", {"robot": robot, "positions": q.tolist()})["pose"]
        every = client.post("/v1/ik", json={"robot": robot, "pose": pose, "all": True})
        missed += every.status_code == 422
        x = np.array(ok(client, "/v1/ik", {"robot": robot, "pose": pose})["positions"])
        assert np.all(x >= lo) and np.all(x <= hi)
        pin.framesForwardKinematics(model, data, reference_q(model, d["joint_names"], x))
        reached = data.oMf[base].actInv(data.oMf[tip]).homogeneous
        np.testing.assert_allclose(reached, pose_matrix(pose), atol=1e-8)
    assert missed > 0  # all: true holds joint 7 and the finger: some poses have no solution there


SWEEP: dict[str, tuple[str, str, str]] = {
    **{name: ARMS[name][:3] for name in ARMS},
    "ur5_world_ee": ("ur5_robot.urdf", "world", "ee_link"),
    "panda_finger": ("panda.urdf", "panda_link0", "panda_leftfinger"),  # 7 revolute + prismatic
    "jaco2_fingertip": ("kinova_j2s6s200.urdf", "j2s6s200_link_base", "j2s6s200_link_finger_tip_1"),
    "pendulum": ("double_pendulum_continuous.urdf", "base_link", "link2"),  # continuous joints
    "quadruped_leg": ("quadruped.urdf", "base_link", "FL_contact"),  # a joint with range [0, 0]
    "gen3_lite": ("kortex_gen3_lite.urdf", "BASE", "END_EFFECTOR"),
    "two_joint": ("two_joint_robot.urdf", "base_link", "link_23_cyl"),  # planar: position_xy
}
PLANNING_CODES = {
    "unreachable",
    "joint_limit",
    "branch_flip",
    "singularity",
    "joint_rate_limit",
    "infeasible",
    "no_convergence",
    "collision",
    "validation",
}


def _finite(value: Any) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    if isinstance(value, list):
        return all(_finite(v) for v in value)
    return True


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SWEEP))
def test_every_endpoint_never_fails_badly(client: TestClient, name: str) -> None:
    """Every endpoint, every method, with and without an environment: 200 with finite numbers, or
    a 422 planning failure whose problem names its code (and, for validation, the field)."""
    file, base, tip = SWEEP[name]
    robot = {
        "urdf": (FIXTURES / file).read_text(encoding="utf-8"),
        "base_frame": base,
        "tip_frame": tip,
    }
    d = ok(client, "/v1/robots/describe", {"robot": robot})
    n = d["dof"]
    lo, hi = np.array(d["limits"]["position"]).T
    lo2, hi2 = np.maximum(lo, -3.0), np.minimum(hi, 3.0)
    qa = np.clip((lo2 + hi2) / 2 + 0.25 * (hi2 - lo2) * np.cos(np.arange(n) + 0.5), lo, hi)
    qb = np.clip((lo2 + hi2) / 2 - 0.2 * (hi2 - lo2) * np.sin(np.arange(n) + 1.5), lo, hi)
    fk = ok(client, "/v1/fk", {"robot": robot, "positions": qa.tolist(), "frames": True})
    at, turn = np.array(fk["pose"]["position"]), fk["pose"]["orientation"]
    goal = {"position": (at + np.array([0.01, 0.0, 0.01])).tolist(), "orientation": turn}
    box = {
        "name": "box",
        "shape": {"type": "box", "size": [0.1, 0.1, 0.1]},
        "pose": {
            "position": (at + np.array([0.15, 0.0, 0.0])).tolist(),
            "orientation": [0, 0, 0, 1],
        },
    }
    floor = {"name": "floor", "shape": {"type": "halfspace", "normal": [0, 0, 1], "offset": -2.0}}
    environments = [None, {"obstacles": [box, floor], "clearance": 0.005}]
    requests: list[tuple[str, dict[str, Any]]] = [
        ("/v1/ik", {"robot": robot, "pose": fk["pose"], "all": True, "turns": True}),
        ("/v1/ik", {"robot": robot, "pose": {"position": (at * 10).tolist(), "orientation": turn}}),
        (
            "/v1/trajectories/spline",
            {"robot": robot, "waypoints": [qa.tolist(), qb.tolist(), qa.tolist()]},
        ),
    ]
    for env in environments:
        extra = {} if env is None else {"environment": env}
        requests.append(("/v1/distance", {"robot": robot, "positions": qa.tolist(), **extra}))
        for profile in ("quintic", "trapezoidal", "jerk_limited"):
            body = {
                "robot": robot,
                "profile": profile,
                "start": {"positions": qa.tolist()},
                "goal": {"positions": qb.tolist()},
                "limits": {"jerk": [100.0] * n},
                **extra,
            }
            requests.append(("/v1/trajectories/joint", body))
        task = {
            "robot": robot,
            "start": {"positions": qa.tolist()},
            "goal": {"pose": goal},
            **extra,
        }
        for method in (
            "sampled",
            "bounded_deviation",
            "bounded_deviation_nlp",
            "resolved_rate",
            "resolved_rate_dls",
        ):
            requests.append(("/v1/trajectories/cartesian", {**task, "method": method}))
        requests.append(("/v1/compare", {"task": task, "include_trajectories": True}))
        segments = [
            {"type": "ptp", "goal": {"positions": qb.tolist()}},
            {"type": "ptp", "goal": {"pose": goal}},
            {"type": "lin", "goal": {"positions": qa.tolist()}},
        ]
        requests.append(
            (
                "/v1/trajectories/program",
                {
                    "robot": robot,
                    "start": {"positions": qa.tolist()},
                    "segments": segments,
                    **extra,
                },
            )
        )
    for url, body in requests:
        r = client.post(url, json=body)
        assert r.status_code in (200, 422), f"{url}: {r.status_code} {r.text[:300]}"
        answer = r.json()
        assert _finite(answer), url
        if r.status_code == 422:
            assert answer["code"] in PLANNING_CODES, (url, answer)
            if answer["code"] == "validation":
                assert answer["errors"] and answer["errors"][0]["loc"], (url, answer)
