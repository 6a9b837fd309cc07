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
    } <= set(spec["paths"])
    pose = spec["components"]["schemas"]["Pose"]["properties"]
    assert (
        "[m]" in pose["position"]["description"]
        and "x, y, z, w" in pose["orientation"]["description"]
    )
