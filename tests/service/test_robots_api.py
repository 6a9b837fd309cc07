"""/v1/robots over HTTP: listing, details, FK, IK, and every error the routes answer."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from fastapi.testclient import TestClient

from core.geometry.so3 import quat_to_matrix
from robots import registry
from service.app import create_app
from service.routes import robots as robots_route
from service.settings import Settings
from tests.robots.inline_urdfs import joint, robot


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app()) as c:
        yield c


def problem(response, status: int, code: str) -> dict:
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    body = response.json()
    assert body["code"] == code and body["status"] == status
    return body


def test_list_and_detail(client: TestClient) -> None:
    listing = client.get("/v1/robots").json()
    assert [r["name"] for r in listing] == ["panda", "planar_2r", "puma560", "ur5"]
    planar = next(r for r in listing if r["name"] == "planar_2r")
    assert planar == {
        "name": "planar_2r",
        "dof": 2,
        "joint_names": ["joint1", "joint2"],
        "base_frame": "base_link",
        "tip_frame": "tool0",
        "task_space": "position_xy",
    }
    panda = client.get("/v1/robots/panda").json()
    assert panda["limits"]["acceleration"] == [15, 7.5, 10, 12.5, 15, 20, 20]
    assert panda["limits"]["position"][3] == [-3.0718, -0.0698]
    assert len(panda["home"]) == 7 and set(panda["limit_sources"]) >= {
        "position",
        "velocity",
        "acceleration",
    }


def test_fk_matches_the_model(client: TestClient) -> None:
    ur5 = registry.get("ur5")
    q = [0.1, -1.2, 1.4, -1.7, -1.5, 0.3]
    body = client.post("/v1/robots/ur5/fk", json={"positions": q}).json()
    T = ur5.fk(np.array(q))
    np.testing.assert_allclose(body["pose"]["position"], T[:3, 3], atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(body["pose"]["orientation"]), T[:3, :3], atol=1e-12)
    assert body["pose"]["orientation"][3] >= 0
    np.testing.assert_allclose(body["jacobian"], ur5.jacobian(np.array(q)), atol=1e-12)
    s = np.linalg.svd(ur5.jacobian(np.array(q)), compute_uv=False)
    assert body["min_singular_value"] == pytest.approx(s[-1])
    assert body["manipulability"] == pytest.approx(np.prod(s))


def test_fk_planar_uses_x_and_y_rows(client: TestClient) -> None:
    body = client.post("/v1/robots/planar_2r/fk", json={"positions": [0.0, math.pi / 2]}).json()
    assert body["manipulability"] == pytest.approx(0.8)  # l1 l2 |sin q2|
    assert len(body["jacobian"]) == 6 and len(body["jacobian"][0]) == 2


def test_fk_of_another_frame_and_unknown_frame(client: TestClient) -> None:
    body = client.post("/v1/robots/ur5/fk", json={"positions": [0] * 6, "frame": "shoulder_link"})
    assert body.status_code == 200
    np.testing.assert_allclose(body.json()["pose"]["position"], [0, 0, 0.089159], atol=1e-12)
    err = problem(
        client.post("/v1/robots/ur5/fk", json={"positions": [0] * 6, "frame": "gripper"}),
        404,
        "unknown_frame",
    )
    assert "tool0" in err["frames"] and "gripper" not in err["detail"]


@pytest.mark.parametrize("name", ["ur5", "panda", "puma560", "planar_2r"])
def test_ik_round_trip(client: TestClient, name: str) -> None:
    robot = registry.get(name)
    q = robot.home + 0.2
    pose = client.post(f"/v1/robots/{name}/fk", json={"positions": q.tolist()}).json()["pose"]
    body = client.post(f"/v1/robots/{name}/ik", json={"pose": pose, "seed": robot.home.tolist()})
    assert body.status_code == 200, body.text
    result = body.json()
    T = robot.fk(np.array(result["positions"]))
    assert np.linalg.norm(T[:3, 3] - robot.fk(q)[:3, 3]) <= 1e-6
    assert result["position_error"] <= 1e-6 and result["orientation_error"] <= 1e-6
    # without a seed: from home, then deterministic restarts
    assert client.post(f"/v1/robots/{name}/ik", json={"pose": pose}).status_code == 200


def test_ik_unreachable(client: TestClient) -> None:
    pose = {"position": [2.5, 0, 0.3], "orientation": [0, 0, 0, 1]}
    body = problem(client.post("/v1/robots/ur5/ik", json={"pose": pose}), 422, "unreachable")
    assert body["position_error"] > 1.0


def test_ik_reachable_only_outside_the_limits_is_joint_limit(client, monkeypatch) -> None:
    lim = '<limit lower="{}" upper="{}" velocity="1" effort="1"/>'
    urdf = robot(
        joint("a", "base", "l1", limit=lim.format(-0.1, 0.1)),
        joint("b", "l1", "l2", xyz="1 0 0", limit=lim.format(0.5, 1.0)),
        joint("t", "l2", "tip", "fixed", xyz="0.8 0 0"),
        links=["base", "l1", "l2", "tip"],
    )
    limited = registry.load_inline(urdf, "tip", "base")
    # the tip at q = (0, -0.8): joint b is outside [0.5, 1]; the mirror branch (q2 = +0.8) needs
    # q1 = -0.66, far outside joint a's +-0.1. Only limit-violating solutions exist.
    x, y = 1.0 + 0.8 * math.cos(-0.8), 0.8 * math.sin(-0.8)
    monkeypatch.setattr(robots_route.registry, "get", lambda name: limited)
    pose = {"position": [x, y, 0.0], "orientation": [0, 0, 0, 1]}
    body = problem(client.post("/v1/robots/limited/ik", json={"pose": pose}), 422, "joint_limit")
    assert body["joint_name"] in {"a", "b"} and "outside its limits" in body["detail"]


def test_validation_errors(client: TestClient) -> None:
    cases = [
        ("/v1/robots/ur5/fk", {"positions": [0] * 5}, ["body", "positions"]),
        ("/v1/robots/ur5/fk", {"positions": [0] * 6, "extra": 1}, ["body", "extra"]),
        ("/v1/robots/ur5/fk", {"positions": [0, 0, 0, 0, 0, 1e5]}, ["body", "positions", 5]),
        ("/v1/robots/ur5/ik", {"pose": {"position": [0, 0], "orientation": [0, 0, 0, 1]}}, None),
        (
            "/v1/robots/ur5/ik",
            {"pose": {"position": [0.3, 0, 0.3], "orientation": [0, 0, 0, 0.9]}},
            None,
        ),
        (
            "/v1/robots/ur5/ik",
            {"pose": {"position": [0.3, 0, 0.3], "orientation": [0, 0, 0, 1]}, "seed": [0]},
            ["body", "seed"],
        ),
    ]
    for path, payload, loc in cases:
        body = problem(client.post(path, json=payload), 422, "validation")
        if loc is not None:
            assert body["errors"][0]["loc"] == loc, body
    nan = client.post(
        "/v1/robots/ur5/fk",
        content=b'{"positions": [0, 0, 0, 0, 0, NaN]}',
        headers={"content-type": "application/json"},
    )
    problem(nan, 422, "validation")


def test_quaternion_within_1e_3_is_normalized(client: TestClient) -> None:
    ur5 = registry.get("ur5")
    pose = client.post("/v1/robots/ur5/fk", json={"positions": ur5.home.tolist()}).json()["pose"]
    pose["orientation"] = [1.0009 * v for v in pose["orientation"]]
    body = client.post("/v1/robots/ur5/ik", json={"pose": pose, "seed": ur5.home.tolist()})
    assert body.status_code == 200 and body.json()["orientation_error"] <= 1e-6


def test_joint_limit_names_the_joint(client: TestClient) -> None:
    body = problem(
        client.post("/v1/robots/panda/fk", json={"positions": [0, 0, 0, 0.5, 0, 1, 0]}),
        422,
        "joint_limit",
    )
    assert body["joint"] == 3 and body["joint_name"] == "panda_joint4"
    assert body["errors"][0]["loc"] == ["body", "positions", 3]


def test_unknown_robot(client: TestClient) -> None:
    body = problem(client.post("/v1/robots/kuka/fk", json={"positions": [0]}), 404, "unknown_robot")
    assert body["available"] == ["panda", "planar_2r", "puma560", "ur5"]
    problem(client.get("/v1/robots/kuka"), 404, "unknown_robot")


def test_concurrent_fk_requests_agree_with_serial(client: TestClient) -> None:
    rng = np.random.default_rng(0)
    payloads = [
        (
            name,
            rng.uniform(-1, 1, registry.get(name).dof).clip(*registry.get(name).position_limits.T),
        )
        for name in ["ur5", "panda", "puma560", "planar_2r"] * 16
    ]

    def call(item):
        name, q = item
        return client.post(f"/v1/robots/{name}/fk", json={"positions": q.tolist()}).json()

    serial = [call(p) for p in payloads]
    with ThreadPoolExecutor(max_workers=8) as pool:
        parallel = list(pool.map(call, payloads))
    assert parallel == serial


def test_openapi_documents_units(client: TestClient) -> None:
    spec = client.get("/openapi.json").json()
    assert {
        "/v1/robots",
        "/v1/robots/{name}",
        "/v1/robots/{name}/fk",
        "/v1/robots/{name}/ik",
        "/v1/robots/describe",
        "/v1/fk",
        "/v1/ik",
    } <= set(spec["paths"])
    pose = spec["components"]["schemas"]["Pose"]["properties"]
    assert (
        "[m]" in pose["position"]["description"]
        and "x, y, z, w" in pose["orientation"]["description"]
    )


# --- every IK solution, configurations, inline robots (round 2) -----------------------------------

UR5_Q = [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]


def wrap(d: np.ndarray) -> np.ndarray:
    return (d + math.pi) % (2 * math.pi) - math.pi


def pose_of(robot_name: str, q) -> dict:
    from service.schemas.common import Pose

    return Pose.from_matrix(registry.get(robot_name).fk(np.asarray(q, dtype=float))).model_dump()


def test_detail_lists_ik_solver_and_configurations(client: TestClient) -> None:
    ur5 = client.get("/v1/robots/ur5").json()
    assert ur5["ik"] == {"solver": "analytic", "max_solutions": 8, "redundant_joints": []}
    assert len(ur5["configurations"]) == 8 and "right-up-noflip" in ur5["configurations"]
    panda = client.get("/v1/robots/panda").json()
    assert panda["ik"]["redundant_joints"] == ["panda_joint7"] and panda["configurations"] == []
    planar = client.get("/v1/robots/planar_2r").json()
    assert planar["ik"]["max_solutions"] == 2 and planar["configurations"] == ["down", "up"]
    described = client.post("/v1/robots/describe", json={"robot": "ur5"}).json()
    assert described == ur5


def test_fk_configuration_and_every_link_frame(client: TestClient) -> None:
    ur5 = registry.get("ur5")
    body = client.post("/v1/robots/ur5/fk", json={"positions": UR5_Q, "frames": True}).json()
    assert body["configuration"] == ur5.configuration(np.array(UR5_Q))
    names = [f["name"] for f in body["frames"]]
    assert names[0] == "base_link" and names[-1] == "tool0" and "wrist_2_link" in names
    for frame in body["frames"]:  # each equals the model's frame pose
        T = ur5.frame_pose(np.array(UR5_Q), frame["name"])
        np.testing.assert_allclose(frame["position"], T[:3, 3], atol=1e-12)
        np.testing.assert_allclose(quat_to_matrix(frame["orientation"]), T[:3, :3], atol=1e-12)
    plain = client.post("/v1/robots/ur5/fk", json={"positions": UR5_Q}).json()
    assert plain["frames"] is None


@pytest.mark.parametrize("name", ["ur5", "puma560"])
def test_ik_all_every_solution_reproduces_the_pose(client: TestClient, name: str) -> None:
    robot = registry.get(name)
    q = robot.home + np.array([0.2, -0.15, 0.25, 0.3, 0.35, -0.2])
    T = robot.fk(q)
    body = client.post(
        f"/v1/robots/{name}/ik", json={"pose": pose_of(name, q), "all": True, "seed": q.tolist()}
    ).json()
    assert body["solver"] == "analytic"
    sols = body["solutions"]
    Q = np.array([s["positions"] for s in sols])
    assert np.abs(Q[0] - q).max() <= 1e-7  # nearest the seed first
    dist = np.linalg.norm(Q - q, axis=1)
    assert np.all(np.diff(dist) >= 0)
    for s, x in zip(sols, Q, strict=True):
        Tx = robot.fk(x)
        # the pose went through a quaternion: compare to its rounding, not to 1e-9 of T itself
        assert np.linalg.norm(Tx[:3, 3] - T[:3, 3]) <= 1e-9
        assert np.abs(Tx[:3, :3] - T[:3, :3]).max() <= 1e-9
        assert s["configuration"] == robot.configuration(x)
        fk = client.post(f"/v1/robots/{name}/fk", json={"positions": s["positions"]}).json()
        assert fk["configuration"] == s["configuration"]
        assert s["position_error"] <= 1e-9 and s["orientation_error"] <= 1e-9
    labels = [s["configuration"] for s in sols]
    assert len(set(labels)) == len(labels)
    if name == "ur5":
        assert len(sols) == 8


def test_ik_with_a_configuration_and_unknown_or_absent_labels(client: TestClient) -> None:
    ur5 = registry.get("ur5")
    pose = pose_of("ur5", UR5_Q)
    every = client.post("/v1/robots/ur5/ik", json={"pose": pose, "all": True}).json()["solutions"]
    target = every[-1]  # the farthest from home
    one = client.post(
        "/v1/robots/ur5/ik", json={"pose": pose, "configuration": target["configuration"]}
    ).json()
    assert one["configuration"] == target["configuration"]
    assert ur5.configuration(np.array(one["positions"])) == target["configuration"]
    np.testing.assert_allclose(one["positions"], target["positions"], atol=1e-9)
    bad = problem(
        client.post("/v1/robots/ur5/ik", json={"pose": pose, "configuration": "sideways"}),
        422,
        "validation",
    )
    assert bad["errors"][0]["loc"] == ["body", "configuration"]
    assert set(bad["configurations"]) == set(ur5.configuration_labels)
    # a PUMA pose whose limits leave fewer than 8 labels: a missing one is unreachable, named
    puma = registry.get("puma560")
    q = np.array([0.2, 0.9, -2.6, 0.3, 0.8, 0.1])
    pose = pose_of("puma560", q)
    found = client.post("/v1/robots/puma560/ik", json={"pose": pose, "all": True}).json()
    labels = {s["configuration"] for s in found["solutions"]}
    missing = sorted(set(puma.configuration_labels) - labels)
    assert missing
    body = problem(
        client.post("/v1/robots/puma560/ik", json={"pose": pose, "configuration": missing[0]}),
        422,
        "unreachable",
    )
    assert set(body["configurations"]) == labels


def test_ik_turns(client: TestClient) -> None:
    pose = pose_of("ur5", UR5_Q)
    one = client.post("/v1/robots/ur5/ik", json={"pose": pose, "all": True}).json()
    every = client.post("/v1/robots/ur5/ik", json={"pose": pose, "all": True, "turns": True}).json()
    assert len(every["solutions"]) == 64 * len(one["solutions"])
    Q = np.array([s["positions"] for s in every["solutions"]])
    assert np.all(np.abs(Q) <= 2 * math.pi)


def test_fixed_joints(client: TestClient) -> None:
    panda = registry.get("panda")
    q = np.array([0.2, -0.5, 0.3, -2.0, 0.4, 1.7, 0.6])
    pose = pose_of("panda", q)
    body = client.post(
        "/v1/robots/panda/ik",
        json={"pose": pose, "all": True, "fixed_joints": {"panda_joint7": 0.6}},
    ).json()
    Q = np.array([s["positions"] for s in body["solutions"]])
    assert np.all(Q[:, 6] == 0.6) and body["solver"] == "analytic"
    assert np.abs(wrap(Q - q)).max(axis=1).min() <= 1e-7
    for x in Q:
        assert np.linalg.norm(panda.fk(x)[:3, 3] - panda.fk(q)[:3, 3]) <= 1e-9
    cases = [
        ({"nope": 0.1}, 422, "validation", ["body", "fixed_joints", "nope"]),
        ({"panda_joint2": 0.1}, 422, "validation", ["body", "fixed_joints", "panda_joint2"]),
        ({"panda_joint7": 3.5}, 422, "joint_limit", ["body", "fixed_joints", "panda_joint7"]),
        ({"x" * 300: 0.1}, 422, "validation", None),
        ({"panda_joint7": 1e9}, 422, "validation", None),
    ]
    for fixed, status, code, loc in cases:
        err = problem(
            client.post("/v1/robots/panda/ik", json={"pose": pose, "fixed_joints": fixed}),
            status,
            code,
        )
        assert loc is None or err["errors"][0]["loc"] == loc
    err = problem(
        client.post("/v1/robots/ur5/ik", json={"pose": pose, "fixed_joints": {"wrist_3_joint": 0}}),
        422,
        "validation",
    )
    assert err["redundant_joints"] == []


def test_one_solution_releases_the_held_joint_before_unreachable(client: TestClient) -> None:
    # a reachable pose (FK of q inside the limits) with no solution at joint 7 = home's value:
    # all: true holds it there (none: 422), all: false looks further and answers one
    panda = registry.get("panda")
    lo, hi = panda.position_limits.T
    qs = np.random.default_rng(5).uniform(lo, hi, (40, 7))
    q = next(q for q in qs if not len(panda.ik_all(panda.fk(q))))
    pose = pose_of("panda", q)
    held = problem(
        client.post("/v1/robots/panda/ik", json={"pose": pose, "all": True}), 422, "unreachable"
    )  # it was 422 joint_limit "reachable only with joint ... outside its limits": untrue
    assert held["redundant_joints"] == ["panda_joint7"] and "all: false" in held["detail"]
    one = client.post("/v1/robots/panda/ik", json={"pose": pose})
    assert one.status_code == 200, one.text
    x = np.array(one.json()["positions"])
    assert np.all(x >= lo) and np.all(x <= hi) and one.json()["solver"] == "analytic"
    np.testing.assert_allclose(panda.fk(x), panda.fk(q), atol=1e-9)
    # the second effort is bounded by the request's deadline: with none left it does not run
    with TestClient(create_app(Settings(time_budget_s=1e-9))) as spent:
        r = spent.post("/v1/robots/panda/ik", json={"pose": pose})
    assert r.status_code == 422 and r.json()["code"] == "unreachable", r.text


def test_unreachable_names_the_reach(client: TestClient) -> None:
    pose = {"position": [2.5, 0, 0.3], "orientation": [0, 0, 0, 1]}
    body = problem(
        client.post("/v1/robots/ur5/ik", json={"pose": pose, "all": True}), 422, "unreachable"
    )
    assert 0.9 < body["reach"] < 1.3 and body["distance"] > body["reach"]
    assert "reaches at most" in body["detail"]


def test_inline_robot_routes(client: TestClient) -> None:
    from tests.robots.test_ik_all import ur_urdf

    inline = {
        "urdf": ur_urdf(0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
        "tip_frame": "tool",
        "base_frame": "world",
    }
    robot_model = registry.load_inline(inline["urdf"], "tool", "world")
    described = client.post("/v1/robots/describe", json={"robot": inline}).json()
    assert described["ik"]["solver"] == "analytic" and len(described["configurations"]) == 8
    q = [0.4, -1.1, 1.5, -1.9, -1.2, 0.7]
    fk = client.post("/v1/fk", json={"robot": inline, "positions": q}).json()
    assert fk["configuration"] == robot_model.configuration(np.array(q))
    ik = client.post("/v1/ik", json={"robot": inline, "pose": fk["pose"], "all": True}).json()
    assert ik["solver"] == "analytic" and len(ik["solutions"]) >= 1
    assert any(np.abs(wrap(np.array(s["positions"]) - q)).max() <= 1e-7 for s in ik["solutions"])
    # a registered name works through the same routes
    assert client.post("/v1/fk", json={"robot": "ur5", "positions": UR5_Q}).json()["configuration"]
    problem(client.post("/v1/fk", json={"robot": inline, "positions": q[:5]}), 422, "validation")
    problem(client.post("/v1/ik", json={"robot": "r2d2", "pose": fk["pose"]}), 404, "unknown_robot")


def test_shared_link_and_joint_name_through_the_api(client: TestClient) -> None:
    from tests.robots.test_shared_names import Q6, SHARED

    inline = {"urdf": SHARED, "tip_frame": "palm", "base_frame": "base"}
    fk = client.post("/v1/fk", json={"robot": inline, "positions": Q6.tolist(), "frames": True})
    assert fk.status_code == 200, fk.text
    names = [f["name"] for f in fk.json()["frames"]]
    assert names.count("gripper") == 1 and names.count("wrist") == 1
    ik = client.post(
        "/v1/ik", json={"robot": inline, "pose": fk.json()["pose"], "seed": Q6.tolist()}
    )
    assert ik.status_code == 200, ik.text
    np.testing.assert_allclose(ik.json()["positions"], Q6, atol=1e-7)


def test_singular_pose_answers_representatives_with_a_warning(client: TestClient) -> None:
    q = [0.3, -1.2, 1.8, -2.2, 0.0, 0.4]  # UR5 wrist singular: q5 = 0
    pose = pose_of("ur5", q)
    body = client.post("/v1/robots/ur5/ik", json={"pose": pose, "all": True}).json()
    assert body["solutions"] and "singular" in body["warnings"][0]
    one = client.post("/v1/robots/ur5/ik", json={"pose": pose, "seed": q}).json()
    assert one["warnings"] and one["position_error"] <= 1e-9
    generic = client.post("/v1/robots/ur5/ik", json={"pose": pose_of("ur5", UR5_Q)}).json()
    assert generic["warnings"] == []
