"""The environment through the API: first contact of a LIN against a ball and a table (s against a
closed form), a joint move through an obstacle, start/goal in collision, partial plans, the distance
endpoints, and every bad-input rule of API.md "Environment and collisions"."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from robots import registry
from robots.collision import MAX_CAPSULES
from robots.geometry import ROBOT_GEOMETRY
from service.app import create_app
from service.convert.environment import collision_check as checker
from service.routes.collision import collision_description
from service.schemas.common import Pose
from service.schemas.environment import Environment
from tests.service.helpers import problem

UR5 = registry.get("ur5")
HOME = UR5.home.tolist()
IDENTITY = [0.0, 0.0, 0.0, 1.0]
TABLE = {"name": "table", "shape": {"type": "halfspace", "normal": [0, 0, 1], "offset": 0.0}}


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def ball(name: str, center, radius: float) -> dict:
    return {
        "name": name,
        "shape": {"type": "sphere", "radius": radius},
        "pose": {"position": list(map(float, center)), "orientation": IDENTITY},
    }


def tool_capsule(q) -> tuple[np.ndarray, np.ndarray, float]:
    """The UR5 tool capsule (wrist_3_link) in the base frame, placed by pinocchio."""
    (c,) = [c for c in ROBOT_GEOMETRY["ur5"].capsules if c.link == "wrist_3_link"]
    T = UR5.frame_pose(np.asarray(q), "wrist_3_link")
    return T[:3, :3] @ np.array(c.a) + T[:3, 3], T[:3, :3] @ np.array(c.b) + T[:3, 3], c.radius


def point_segment(p, a, b) -> float:
    d = b - a
    t = float(np.clip((p - a) @ d / (d @ d), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * d)))


def lin_body(offset, **extra) -> dict:
    T0 = UR5.fk(UR5.home)
    T1 = T0.copy()
    T1[:3, 3] += offset
    goal = Pose.from_matrix(T1).model_dump()
    return {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"pose": goal},
        "method": "sampled",
        **extra,
    }


def first_touch_s(distance_at) -> float:
    """The smallest s in [0, 1] (to 1e-5) where ``distance_at(s) <= 0``, by a dense scan."""
    s = np.linspace(0.0, 1.0, 100_001)
    d = np.array([distance_at(x) for x in s[::100]])  # coarse, then fine near the crossing
    k = int(np.argmax(d <= 0))
    fine = s[max(0, (k - 1) * 100) : k * 100 + 1]
    df = np.array([distance_at(x) for x in fine])
    return float(fine[int(np.argmax(df <= 0))])


def test_lin_into_a_ball_fails_where_the_tool_capsule_first_touches_it(client) -> None:
    offset = np.array([0.0, 0.3, 0.0])
    p0 = UR5.fk(UR5.home)[:3, 3]
    center, R = p0 + 0.7 * offset, 0.03
    body = lin_body(offset, environment={"obstacles": [ball("ball", center, R)]})
    err = problem(client.post("/v1/trajectories/cartesian", json=body), 422, "collision")
    assert err["links"] == ["wrist_3_link", "ball"]
    a0, b0, r = tool_capsule(UR5.home)
    # orientation is constant on this line: the capsule translates with the tool point
    s_star = first_touch_s(
        lambda s: point_segment(center, a0 + s * offset, b0 + s * offset) - r - R
    )
    assert err["s"] == pytest.approx(s_star, abs=0.01)
    assert err["distance"] <= 0 and err["time_from_start"] > 0


def test_lin_down_through_a_table_is_a_goal_collision(client) -> None:
    body = lin_body(np.array([0.0, 0.0, -0.23]), environment={"obstacles": [TABLE]})
    assert UR5.fk(UR5.home)[2, 3] - 0.23 < 0  # the goal is below the table top
    err = problem(client.post("/v1/trajectories/cartesian", json=body), 422, "collision")
    assert err["links"] == ["wrist_3_link", "table"] and err["at"] == "goal"
    assert "goal" in err["detail"] and err["s"] == pytest.approx(1.0, abs=1e-6)


def test_allow_partial_returns_the_clear_prefix(client) -> None:
    offset = np.array([0.0, 0.3, 0.0])
    center, R = UR5.fk(UR5.home)[:3, 3] + 0.7 * offset, 0.03
    body = lin_body(
        offset, environment={"obstacles": [ball("ball", center, R)]}, allow_partial=True
    )
    resp = client.post("/v1/trajectories/cartesian", json=body)
    assert resp.status_code == 200, resp.text
    doc = resp.json()
    failure = doc["diagnostics"]["failure"]
    assert failure["code"] == "collision"
    assert doc["diagnostics"]["fraction"] <= failure["s"] + 1e-9 < 1.0
    assert doc["diagnostics"]["fraction"] > failure["s"] - 0.05
    a, b, r = tool_capsule(doc["points"][-1]["positions"])
    assert point_segment(center, a, b) - r - R >= 0


def test_joint_goal_below_the_table_is_a_goal_collision(client) -> None:
    goal = np.array(HOME)
    goal[1] += 0.9  # shoulder lift down: the tool goes below the table top
    assert UR5.fk(goal)[2, 3] < 0
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"positions": goal.tolist()},
        "profile": "quintic",
        "environment": {"obstacles": [TABLE]},
    }
    err = problem(client.post("/v1/trajectories/joint", json=body), 422, "collision")
    assert "goal" in err["detail"] and err["at"] == "goal"
    assert err["links"][1] == "table"
    body["start"], body["goal"] = body["goal"], body["start"]
    err = problem(client.post("/v1/trajectories/joint", json=body), 422, "collision")
    assert "start" in err["detail"] and err["at"] == "start"


def test_joint_move_through_an_obstacle_between_clear_ends(client) -> None:
    """Two returned points only (samples=2): both clear; the continuous check still finds the ball
    that the middle of the swing passes through."""
    q0 = np.array(HOME)
    q1 = q0.copy()
    q1[0] += 2.0
    center = UR5.fk((q0 + q1) / 2)[:3, 3]
    body = {
        "robot": "ur5",
        "start": {"positions": q0.tolist()},
        "goal": {"positions": q1.tolist()},
        "profile": "linear",
        "duration": 2.0,
        "samples": 2,
        "environment": {"obstacles": [ball("ball", center, 0.05)]},
    }
    err = problem(client.post("/v1/trajectories/joint", json=body), 422, "collision")
    assert err["links"][1] == "ball" and 0 < err["time_from_start"] < 1.0
    body["environment"]["obstacles"][0]["pose"]["position"][2] += 1.0  # lift it out of the way
    doc = client.post("/v1/trajectories/joint", json=body).json()
    assert doc["diagnostics"]["min_clearance"] > 0
    assert doc["diagnostics"]["closest"]["links"][0] in {
        c.link for c in ROBOT_GEOMETRY["ur5"].capsules
    }


def test_min_clearance_equals_an_independent_distance(client) -> None:
    goal = np.array(HOME)
    goal[0] += 0.3
    center, R = UR5.fk(goal)[:3, 3] + [0.0, 0.0, -0.15], 0.05  # under the tool at the goal
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"positions": goal.tolist()},
        "profile": "quintic",
        "environment": {"obstacles": [ball("ball", center, R)], "self_collision": False},
    }
    doc = client.post("/v1/trajectories/joint", json=body).json()
    qs = np.array([p["positions"] for p in doc["points"]])
    s = np.linspace(0, 1, 21)[:-1]  # joints linear between the returned points: 20 per segment
    dense = np.vstack(
        [(qs[:-1, None] + s[:, None] * (qs[1:] - qs[:-1])[:, None]).reshape(-1, 6), qs[-1:]]
    )
    ref = min(point_segment(center, *tool_capsule(q)[:2]) - tool_capsule(q)[2] - R for q in dense)
    assert doc["diagnostics"]["closest"]["links"] == ["wrist_3_link", "ball"]
    # certified: a lower bound of the motion's minimum (between the points too), within 1e-4 m
    assert ref - 1e-4 <= doc["diagnostics"]["min_clearance"] <= ref + 1e-12


def ur5_capsules_world(q) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Every UR5 capsule in the base frame, placed by pinocchio's frame poses."""
    out = []
    for c in ROBOT_GEOMETRY["ur5"].capsules:
        T = UR5.frame_pose(np.asarray(q), c.link)
        out.append(
            (T[:3, :3] @ np.array(c.a) + T[:3, 3], T[:3, :3] @ np.array(c.b) + T[:3, 3], c.radius)
        )
    return out


@pytest.mark.parametrize("samples", [500, 37])
def test_clearance_profile_is_the_smallest_distance_at_returned_points(client, samples) -> None:
    """``clearance_profile``: at most 200 returned points, evenly spread, both ends; each value is the
    smallest closed-form capsule-to-ball distance at that point; its minimum is no smaller than
    ``min_clearance`` (the continuous minimum)."""
    goal = np.array(HOME)
    goal[0] += 0.6
    balls = [
        (UR5.fk(goal)[:3, 3] + [0.0, 0.0, -0.12], 0.05),
        (UR5.fk(np.array(HOME))[:3, 3] + [0.0, 0.0, -0.15], 0.04),
    ]
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"positions": goal.tolist()},
        "profile": "quintic",
        "samples": samples,
        "environment": {
            "obstacles": [ball(f"b{i}", c, r) for i, (c, r) in enumerate(balls)],
            "self_collision": False,
        },
    }
    resp = client.post("/v1/trajectories/joint", json=body)
    assert resp.status_code == 200, resp.text
    doc = resp.json()
    prof = doc["diagnostics"]["clearance_profile"]
    times = np.array([p["time_from_start"] for p in doc["points"]])
    assert len(times) == samples
    t, v = np.array(prof["time_from_start"]), np.array(prof["value"])
    assert len(t) == len(v) == min(samples, 200)
    rows = np.searchsorted(times, t)
    np.testing.assert_array_equal(times[rows], t)  # returned times, exactly
    assert rows[0] == 0 and rows[-1] == samples - 1 and (np.diff(rows) > 0).all()
    assert np.diff(rows).max() - np.diff(rows).min() <= 1  # evenly spread
    ref = [
        min(
            point_segment(c, a, b) - rc - r
            for a, b, rc in ur5_capsules_world(doc["points"][k]["positions"])
            for c, r in balls
        )
        for k in rows
    ]
    np.testing.assert_allclose(v, ref, rtol=0, atol=1e-6)
    assert v.min() >= doc["diagnostics"]["min_clearance"] - 1e-9


def test_clearance_profile_of_a_partial_plan_covers_the_returned_prefix(client) -> None:
    offset = np.array([0.0, 0.3, 0.0])
    center, R = UR5.fk(UR5.home)[:3, 3] + 0.7 * offset, 0.03
    body = lin_body(
        offset, environment={"obstacles": [ball("ball", center, R)]}, allow_partial=True
    )
    resp = client.post("/v1/trajectories/cartesian", json=body)
    assert resp.status_code == 200, resp.text
    doc = resp.json()
    times = [p["time_from_start"] for p in doc["points"]]
    prof = doc["diagnostics"]["clearance_profile"]
    assert prof["time_from_start"][-1] == times[-1] and prof["time_from_start"][0] == times[0]
    assert set(prof["time_from_start"]) <= set(times)
    assert doc["diagnostics"]["failure"]["code"] == "collision"
    # only the clear prefix: its profile and its min_clearance (the contact is in failure)
    assert 0 <= doc["diagnostics"]["min_clearance"] <= min(prof["value"]) + 1e-12
    assert doc["diagnostics"]["failure"]["distance"] <= 0


def test_panda_self_collision_through_the_api(client) -> None:
    panda = registry.get("panda")
    goal = np.array([0.0, 1.5, 0.0, -0.3, 0.0, 3.5, 0.0])  # folds the wrist back into the arm
    resp = client.post("/v1/robots/panda/distance", json={"positions": goal.tolist()})
    assert resp.status_code == 200
    assert resp.json()["min_distance"] < 0
    body = {
        "robot": "panda",
        "start": {"positions": panda.home.tolist()},
        "goal": {"positions": goal.tolist()},
        "profile": "quintic",
    }
    err = problem(client.post("/v1/trajectories/joint", json=body), 422, "collision")
    assert all(n.startswith("panda_link") for n in err["links"]) and err["at"] == "goal"
    body["environment"] = {"self_collision": False}
    assert client.post("/v1/trajectories/joint", json=body).status_code == 200


def test_self_collision_is_checked_without_environment(client) -> None:
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"positions": (np.array(HOME) + 0.2).tolist()},
        "profile": "quintic",
    }
    doc = client.post("/v1/trajectories/joint", json=body).json()
    assert doc["diagnostics"]["min_clearance"] > 0
    body.pop("robot")
    body["limits"] = {"velocity": [1.0] * 6, "acceleration": [1.0] * 6}
    doc = client.post("/v1/trajectories/joint", json=body).json()
    assert "min_clearance" not in doc["diagnostics"]


def test_spline_and_compare_carry_the_environment(client) -> None:
    body = {
        "robot": "ur5",
        "waypoints": [HOME, [0.2, *HOME[1:]], [0.4, *HOME[1:]]],
        "boundary": "natural",
        "environment": {"obstacles": [{**TABLE, "shape": {**TABLE["shape"], "offset": -0.05}}]},
    }
    resp = client.post("/v1/trajectories/spline", json=body)
    assert resp.status_code == 200, resp.text
    assert resp.json()["diagnostics"]["min_clearance"] > 0
    prof = resp.json()["diagnostics"]["clearance_profile"]
    assert len(prof["value"]) == len(resp.json()["points"])
    offset = np.array([0.0, 0.0, -0.23])
    task = lin_body(offset, environment={"obstacles": [TABLE]})
    task.pop("method")
    resp = client.post("/v1/compare", json={"task": task, "methods": ["sampled"]})
    row = resp.json()["results"][0]
    assert not row["ok"] and row["error"]["code"] == "collision"
    task["environment"] = {"obstacles": [{**TABLE, "shape": {**TABLE["shape"], "offset": -0.5}}]}
    resp = client.post("/v1/compare", json={"task": task, "methods": ["sampled"]})
    row = resp.json()["results"][0]
    assert row["ok"], row
    prof = row["diagnostics"]["clearance_profile"]
    assert 2 <= len(prof["value"]) <= 200 and prof["time_from_start"][0] == 0.0
    assert min(prof["value"]) >= row["diagnostics"]["min_clearance"] - 1e-9


def test_distance_endpoint_against_a_closed_form(client) -> None:
    center, R = np.array([0.3, -0.3, 0.5]), 0.1
    body = {"positions": HOME, "environment": {"obstacles": [ball("ball", center, R), TABLE]}}
    doc = client.post("/v1/robots/ur5/distance", json=body).json()
    pairs = doc["pairs"]
    assert 0 < len(pairs) <= 20
    d = [p["distance"] for p in pairs]
    assert d == sorted(d) and doc["min_distance"] == d[0]
    for p in pairs:
        a, b = np.array(p["points"])
        if p["distance"] > 0:
            assert np.linalg.norm(a - b) == pytest.approx(p["distance"], abs=1e-6)
    assert client.post("/v1/distance", json={**body, "robot": "ur5"}).json() == doc
    only = {"positions": HOME, "environment": {"obstacles": [ball("ball", center, R)]}}
    only["environment"]["self_collision"] = False
    pairs = client.post("/v1/robots/ur5/distance", json=only).json()["pairs"]
    assert (
        len(pairs) == len(set(c.link for c in ROBOT_GEOMETRY["ur5"].capsules)) - 1
    )  # not the base
    (w3,) = [p for p in pairs if p["links"] == ["wrist_3_link", "ball"]]
    a, b, r = tool_capsule(HOME)
    assert w3["distance"] == pytest.approx(point_segment(center, a, b) - r - R, abs=1e-6)


def test_inline_urdf_collision_primitives_and_mesh_warning(client) -> None:
    urdf = """<robot name="arm">
      <link name="base"/>
      <link name="l1"><collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.06 0.06"/>
        </geometry></collision></link>
      <link name="l2"><collision><geometry><mesh filename="l2.stl"/></geometry></collision></link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
        <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1"/></joint>
    </robot>"""
    robot = {"urdf": urdf, "tip_frame": "l2", "base_frame": "base"}
    body = {
        "robot": robot,
        "positions": [0.0, 0.0],
        "environment": {"obstacles": [ball("ball", [0.25, 0.5, 0.0], 0.1)]},
    }
    doc = client.post("/v1/distance", json=body).json()
    (pair,) = doc["pairs"]
    assert pair["links"] == ["l1", "ball"]
    # the box is checked as a box (it was enclosed in a capsule, 0.33 m): exactly 0.5 - 0.03 - 0.1
    assert pair["distance"] == pytest.approx(0.5 - 0.03 - 0.1, abs=1e-6)
    plan = {
        "robot": robot,
        "start": {"positions": [0.0, 0.0]},
        "goal": {"positions": [0.5, 0.0]},
        "profile": "quintic",
        "environment": {"obstacles": [ball("ball", [0.25, 0.5, 0.0], 0.1)]},
    }
    doc = client.post("/v1/trajectories/joint", json=plan).json()
    assert any("l2" in w for w in doc["diagnostics"]["collision_warnings"])


def environment_error(client, env: dict, status: int = 422) -> dict:
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"positions": HOME},
        "profile": "quintic",
        "duration": 1.0,
        "environment": env,
    }
    return problem(client.post("/v1/trajectories/joint", json=body), status, "validation")


def locs(err: dict) -> list[list]:
    return [e["loc"] for e in err["errors"]]


def test_bad_environments_are_422_at_the_field(client) -> None:
    sphere = ball("a", [1, 1, 1], 0.1)
    err = environment_error(client, {"obstacles": [sphere, sphere]})
    assert any("obstacles" in loc for loc in locs(err))
    err = environment_error(client, {"obstacles": [sphere], "allowed_collisions": [["a", "nope"]]})
    assert ["body", "environment", "allowed_collisions", 0, 1] in locs(err)
    err = environment_error(client, {"obstacles": [ball("wrist_3_link", [1, 1, 1], 0.1)]})
    assert ["body", "environment", "obstacles", 0, "name"] in locs(err)
    for shape in (
        {"type": "sphere", "radius": 0.0},
        {"type": "box", "size": [0.1, -0.1, 0.1]},
        {"type": "cylinder", "radius": 0.1, "length": 0.0},
        {"type": "capsule", "radius": -1.0, "length": 0.1},
        # below a micrometre: coal measured this one as -1.8e308 m with NaN points (a fuzzer's find)
        {"type": "cylinder", "radius": 1e-9, "length": 99.0},
    ):
        err = environment_error(client, {"obstacles": [{"name": "x", "shape": shape}]})
        assert any(loc[:4] == ["body", "environment", "obstacles", 0] for loc in locs(err))
    off = {"name": "h", "shape": {"type": "halfspace", "normal": [0, 0, 1.01], "offset": -1.0}}
    err = environment_error(client, {"obstacles": [off]})
    assert any("normal" in loc for loc in locs(err))
    with_pose = {**TABLE, "pose": {"position": [0, 0, 0], "orientation": IDENTITY}}
    environment_error(client, {"obstacles": [with_pose]})
    many = [ball(f"b{i}", [2 + i, 2, 2], 0.1) for i in range(257)]
    err = environment_error(client, {"obstacles": many})
    assert ["body", "environment", "obstacles"] in locs(err)
    err = environment_error(client, {"clearance": -0.1})
    problem(
        client.post(
            "/v1/trajectories/joint",
            json={
                "start": {"positions": [0.0]},
                "goal": {"positions": [1.0]},
                "limits": {"velocity": [1.0], "acceleration": [1.0]},
                "environment": {},
            },
        ),
        422,
        "validation",
    )


def test_a_nearly_unit_normal_is_normalized(client) -> None:
    tilted = {"name": "t", "shape": {"type": "halfspace", "normal": [0, 0, 1.0005], "offset": -0.5}}
    body = {"positions": HOME, "environment": {"obstacles": [tilted], "self_collision": False}}
    doc = client.post("/v1/robots/ur5/distance", json=body).json()
    exact = {"name": "t", "shape": {"type": "halfspace", "normal": [0, 0, 1], "offset": -0.5}}
    body["environment"]["obstacles"] = [exact]
    assert client.post("/v1/robots/ur5/distance", json=body).json() == doc


def test_distance_endpoint_errors(client) -> None:
    problem(client.post("/v1/robots/nope/distance", json={"positions": HOME}), 404, "unknown_robot")
    problem(client.post("/v1/robots/ur5/distance", json={"positions": [0.0]}), 422, "validation")


def test_collision_description_for_the_robot_resource() -> None:
    """What GET /v1/robots/{name} should add (the robots route belongs to the ik team)."""
    doc = collision_description("panda")
    assert len(doc["collision_geometry"]) == len(ROBOT_GEOMETRY["panda"].capsules)
    first = doc["collision_geometry"][0]
    assert first["link"] == "panda_link0" and first["shape"]["radius"] == 0.06
    pairs = doc["allowed_self_collisions"]
    assert ["panda_link1", "panda_link2"] in pairs and ["panda_link5", "panda_link7"] in pairs
    assert ["panda_link1", "panda_link7"] not in pairs


def test_too_many_inline_collision_primitives_is_too_large(client) -> None:
    spheres = "".join(
        f'<collision><origin xyz="{0.01 * k} 0 0"/><geometry><sphere radius="0.01"/></geometry>'
        "</collision>"
        for k in range(MAX_CAPSULES + 1)
    )
    urdf = f"""<robot name="many"><link name="base"/><link name="l1">{spheres}</link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1"/></joint></robot>"""
    body = {"robot": {"urdf": urdf, "tip_frame": "l1", "base_frame": "base"}, "positions": [0.0]}
    err = problem(client.post("/v1/distance", json=body), 422, "too_large")
    assert err["limit_primitives"] == MAX_CAPSULES == 128


def test_program_collision_names_its_segment_and_s(client) -> None:
    T0 = UR5.fk(UR5.home)
    T1, T2 = T0.copy(), T0.copy()
    T1[:3, 3] += [0.0, 0.0, 0.1]  # first LIN: up, clear
    T2[:3, 3] = T1[:3, 3] + [0.0, 0.3, 0.0]  # second LIN: sideways into the ball
    center, R = T1[:3, 3] + [0.0, 0.21, 0.0], 0.03
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "segments": [
            {"type": "lin", "goal": {"pose": Pose.from_matrix(T1).model_dump()}},
            {"type": "lin", "goal": {"pose": Pose.from_matrix(T2).model_dump()}},
        ],
        "environment": {"obstacles": [ball("ball", center, R)]},
    }
    err = problem(client.post("/v1/trajectories/program", json=body), 422, "collision")
    assert err["segment"] == 1 and err["links"] == ["wrist_3_link", "ball"]
    a0, b0, r = tool_capsule(UR5.home)
    lift = np.array([0.0, 0.0, 0.1])
    offset = np.array([0.0, 0.3, 0.0])
    s_star = first_touch_s(
        lambda s: point_segment(center, a0 + lift + s * offset, b0 + lift + s * offset) - r - R
    )
    assert err["s"] == pytest.approx(s_star, abs=0.01)
    body["allow_partial"] = True
    doc = client.post("/v1/trajectories/program", json=body).json()
    assert doc["diagnostics"]["failure"]["code"] == "collision"
    assert doc["diagnostics"]["failure"]["segment"] == 1
    a, b, r = tool_capsule(doc["points"][-1]["positions"])
    assert point_segment(center, a, b) - r - R >= 0
    prof = doc["diagnostics"]["clearance_profile"]  # the returned prefix, every value clear
    assert prof["time_from_start"][-1] == doc["points"][-1]["time_from_start"]
    assert 0 <= doc["diagnostics"]["min_clearance"] <= min(prof["value"]) + 1e-12
    assert doc["diagnostics"]["closest"]["time_from_start"] <= doc["points"][-1]["time_from_start"]


def shape_ends(entry: dict) -> tuple[np.ndarray, np.ndarray]:
    """The hemisphere centres of a described shape, in its link frame (origin +- length/2 along z)."""
    T = Pose(**entry["origin"]).as_matrix()
    half = entry["shape"].get("length", 0.0) / 2
    return T[:3, 3] - half * T[:3, 2], T[:3, 3] + half * T[:3, 2]


@pytest.mark.parametrize("name", ["panda", "ur5", "puma560"])
def test_robot_description_carries_the_collision_geometry(client, name: str) -> None:
    """GET /v1/robots/{name}: one shape per capsule of ``robots.geometry``, same link, radius and
    segment (link frame), in order; the allowed pairs are those of ``collision_description``."""
    doc = client.get(f"/v1/robots/{name}").json()
    capsules = ROBOT_GEOMETRY[name].capsules
    assert len(doc["collision_geometry"]) == len(capsules)
    for entry, c in zip(doc["collision_geometry"], capsules, strict=True):
        assert entry["link"] == c.link and entry["shape"]["radius"] == c.radius
        p, q = shape_ends(entry)
        a, b = np.array(c.a), np.array(c.b)
        assert entry["shape"]["type"] == ("sphere" if np.allclose(a, b, atol=1e-12) else "capsule")
        np.testing.assert_allclose(p, a, atol=1e-9)
        np.testing.assert_allclose(q, b, atol=1e-9)
    allowed = collision_description(name)["allowed_self_collisions"]
    assert doc["allowed_self_collisions"] == allowed
    assert all(pair == sorted(pair) for pair in allowed)
    same = client.post("/v1/robots/describe", json={"robot": name}).json()
    assert same["collision_geometry"] == doc["collision_geometry"]


def test_inline_description_reports_the_urdf_primitives_as_checked(client) -> None:
    """POST /v1/robots/describe with an inline URDF: the box of l1 (origin x = 0.25, 0.5 long) is
    reported as that box, centred at its origin (it was a capsule enclosing it); a sphere stays a
    sphere at its origin."""
    urdf = """<robot name="arm">
      <link name="base"/>
      <link name="l1"><collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.06 0.06"/>
        </geometry></collision></link>
      <link name="l2"><collision><origin xyz="0.1 0.02 0"/><geometry><sphere radius="0.04"/>
        </geometry></collision></link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
        <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1"/></joint>
      <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
        <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1"/></joint>
    </robot>"""
    robot = {"urdf": urdf, "tip_frame": "l2", "base_frame": "base"}
    doc = client.post("/v1/robots/describe", json={"robot": robot}).json()
    box, sphere = doc["collision_geometry"]
    assert box["link"] == "l1" and box["shape"] == {"type": "box", "size": [0.5, 0.06, 0.06]}
    np.testing.assert_allclose(box["origin"]["position"], [0.25, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(np.abs(box["origin"]["orientation"]), [0, 0, 0, 1], atol=1e-12)
    assert sphere["link"] == "l2" and sphere["shape"] == {"type": "sphere", "radius": 0.04}
    np.testing.assert_allclose(sphere["origin"]["position"], [0.1, 0.02, 0.0], atol=1e-12)
    assert doc["allowed_self_collisions"] == [["l1", "l2"]]


def test_bounded_deviation_nlp_uses_the_tolerance_band_to_pass_a_ball(client) -> None:
    """A ball that the straight line's tool capsule touches (1 mm into it at mid-line): the sampled
    line is 422 collision; the NLP bends the path within the 20 mm band and keeps the clearance,
    measured on the returned points by an independent closed form (ball centre to tool segment)."""
    off = np.array([0.0, 0.3, 0.0])
    a, b, r = tool_capsule(UR5.home)
    R, clearance = 0.05, 0.005
    center = (a + b) / 2 + off / 2 + np.array([-(R + r - 0.001), 0.0, 0.0])
    env = {"obstacles": [ball("ball", center, R)], "clearance": clearance}
    tol = {"position": 0.02, "orientation": 0.01}
    # the straight line: the tool segment passes 1 mm inside the ball's surface (plus the radius)
    straight = point_segment(center, a + off / 2, b + off / 2) - R - r
    assert abs(straight + 0.001) < 1e-9
    err = problem(
        client.post(
            "/v1/trajectories/cartesian",
            json=lin_body(off, method="sampled", environment=env, tolerance=tol),
        ),
        422,
        "collision",
    )
    assert "ball" in err["links"]
    res = client.post(
        "/v1/trajectories/cartesian",
        json=lin_body(off, method="bounded_deviation_nlp", environment=env, tolerance=tol),
    )
    assert res.status_code == 200, res.json()
    doc = res.json()
    diag = doc["diagnostics"]
    assert diag["min_clearance"] >= clearance
    assert diag["max_position_deviation"] <= tol["position"]
    qs = np.array([p["positions"] for p in doc["points"]])
    tool = np.array([point_segment(center, *tool_capsule(q)[:2]) for q in qs]) - R - r
    assert tool.min() >= clearance - 1e-9
    assert tool.min() < clearance + 0.01  # it passes close: the band is used, not a detour


PANDA = registry.get("panda")


def panda_capsules_world(q) -> list[tuple[str, np.ndarray, np.ndarray, float]]:
    """Every Panda capsule in the base frame, placed by pinocchio's frame poses."""
    out = []
    for c in ROBOT_GEOMETRY["panda"].capsules:
        T = PANDA.frame_pose(np.asarray(q), c.link)
        out.append((c.link, T[:3, :3] @ c.a + T[:3, 3], T[:3, :3] @ c.b + T[:3, 3], c.radius))
    return out


def test_resolved_rate_dls_moves_the_elbow_around_a_ball(client) -> None:
    """A Panda LIN (+0.2 m in x, 2 s) whose elbow (panda_link4) would pass 2 mm from a ball with a
    10 mm clearance: sampled is 422 collision; with DLS the velocity dampers keep the clearance
    (closed-form ball-to-capsule distances on the returned points), the tool stays on the line
    within 1 mm, and the elbow leaves the plane it moves in without the ball (null-space motion)."""
    T0 = PANDA.fk(PANDA.home)
    T1 = T0.copy()
    T1[:3, 3] += [0.2, 0.0, 0.0]
    center, R, clearance = np.array([-0.07, 0.172, 0.652]), 0.05, 0.01
    body = {
        "robot": "panda",
        "start": {"positions": PANDA.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T1).model_dump()},
        "duration": 2.0,
        "tolerance": {"position": 1e-3, "orientation": 1e-2},
        "environment": {"obstacles": [ball("ball", center, R)], "clearance": clearance},
    }
    err = problem(
        client.post("/v1/trajectories/cartesian", json={**body, "method": "sampled"}),
        422,
        "collision",
    )
    assert err["links"] == ["panda_link4", "ball"]
    res = client.post("/v1/trajectories/cartesian", json={**body, "method": "resolved_rate_dls"})
    assert res.status_code == 200, res.json()
    doc = res.json()
    assert doc["diagnostics"]["min_clearance"] >= clearance
    qs = np.array([p["positions"] for p in doc["points"]])
    gaps = [
        point_segment(center, a, b) - r - R for q in qs for _, a, b, r in panda_capsules_world(q)
    ]
    assert min(gaps) >= clearance
    # the tool on the line (independent: FK of the returned points against the segment)
    p0, p1 = T0[:3, 3], T1[:3, 3]
    off_line = [point_segment(PANDA.fk(q)[:3, 3], p0, p1) for q in qs]
    assert max(off_line) <= 1e-3
    np.testing.assert_allclose(PANDA.fk(qs[-1])[:3, 3], p1, atol=1e-3)
    # the elbow: in the plane y = 0 without the ball (the arm's symmetry), away from it with it
    free = client.post(
        "/v1/trajectories/cartesian",
        json={**body, "method": "resolved_rate_dls", "environment": None},
    ).json()
    y_free = [
        PANDA.frame_pose(np.array(p["positions"]), "panda_link4")[1, 3] for p in free["points"]
    ]
    y_avoid = [PANDA.frame_pose(q, "panda_link4")[1, 3] for q in qs]
    assert max(abs(y) for y in y_free) < 1e-6
    assert min(y_avoid) < -0.005 and max(y_avoid) < 1e-6


def test_dls_avoidance_needs_osqp(client) -> None:
    body = lin_body([0.0, 0.1, 0.0], method="resolved_rate_dls", environment={"obstacles": []})
    assert client.post("/v1/trajectories/cartesian", json=body).status_code == 200
    err = problem(
        client.post("/v1/trajectories/cartesian", json={**body, "solver": "daqp"}),
        422,
        "validation",
    )
    assert err["errors"][0]["loc"] == ["body", "solver"]
    # without an environment any solver plans as before
    free = {**body, "solver": "daqp", "environment": None}
    assert client.post("/v1/trajectories/cartesian", json=free).status_code == 200


def test_min_distances_skips_only_boxes_that_cannot_be_the_smallest() -> None:
    """``CollisionChecker.min_distances`` (box and cylinder entries skipped by their bounding
    spheres) equals the exact ``distances(...).min(axis=1)`` among boxes and cylinders near and far."""
    rng = np.random.default_rng(3)
    tool = UR5.fk(UR5.home)[:3, 3]
    obstacles = []
    for i in range(10):
        shape = (
            {"type": "box", "size": [0.1, 0.2, 0.05]}
            if i % 2
            else {"type": "cylinder", "radius": 0.04, "length": 0.2}
        )
        q = rng.normal(size=4)
        pose = {
            "position": (tool + rng.uniform(-0.4, 0.4, 3)).tolist(),
            "orientation": (q / np.linalg.norm(q)).tolist(),
        }
        obstacles.append({"name": f"o{i}", "shape": shape, "pose": pose})
    for self_collision in (True, False):
        env = Environment.model_validate({"obstacles": obstacles, "self_collision": self_collision})
        check = checker(UR5, env)
        qs = UR5.home + rng.uniform(-0.8, 0.8, (300, 6))
        exact = check.distances(qs).min(axis=1)
        assert (exact < 0).any() and (exact > 0).any()
        np.testing.assert_allclose(check.min_distances(qs), exact, rtol=0, atol=1e-12)


def _arc_share(p, start, interim, goal, center) -> float:
    """The share of the arc from ``start`` through ``interim`` to ``goal`` about ``center`` swept
    when the tool is at ``p``: its angle from the start over the arc's angle (in [0, 2 pi))."""
    u = start - center
    normal = np.cross(u, interim - center)
    v = np.cross(normal / np.linalg.norm(normal), u)

    def angle(x: np.ndarray) -> float:
        r = x - center
        return float(np.arctan2(r @ v, r @ u)) % (2 * np.pi)

    return angle(p) / angle(goal)


def _tool_at(points: list[dict], t: float) -> np.ndarray:
    """The tool position (pinocchio FK) at time ``t``, joints linear between returned points (as
    the continuous check assumes)."""
    import pinocchio as pin

    times = np.array([p["time_from_start"] for p in points])
    qs = np.array([p["positions"] for p in points])
    q = np.array([np.interp(t, times, qs[:, j]) for j in range(qs.shape[1])])
    data = UR5.model.createData()
    pin.framesForwardKinematics(UR5.model, data, q)
    return data.oMf[UR5.model.getFrameId(UR5.tip_frame)].translation.copy()


@pytest.mark.parametrize("route", ["cartesian", "program"])
def test_a_contact_on_an_arc_is_reported_at_the_tools_own_s(client, route) -> None:
    """Was: s from the projection on the chord (0.179 where the tool was at 0.219). The tool on a
    half circle of radius 0.1 m meets a ball a third of the way along: the reported ``s`` is the
    share of the arc the tool has swept at the reported time (pinocchio FK of the returned motion
    there, against the arc's own geometry), within 0.01."""
    T0 = UR5.fk(UR5.home)
    p0 = T0[:3, 3]
    center = p0 + np.array([0.1, 0.0, 0.0])
    goal, interim = p0 + np.array([0.2, 0.0, 0.0]), p0 + np.array([0.1, 0.1, 0.0])
    phi = np.pi / 3  # the ball sits 60 degrees along, just outside the circle
    ball_at = center + 0.13 * np.array([-np.cos(phi), np.sin(phi), 0.0])
    T1 = T0.copy()
    T1[:3, 3] = goal
    env = {"obstacles": [ball("ball", ball_at, 0.02)]}
    if route == "cartesian":
        body = lin_body(goal - p0, environment=env, samples=100)
        body["path"] = {"type": "circ", "interim": interim.tolist()}
        url = "/v1/trajectories/cartesian"
    else:
        arc = {"type": "circ", "goal": {"pose": Pose.from_matrix(T1).model_dump()},
               "interim": interim.tolist()}  # fmt: skip
        body = {"robot": "ur5", "start": {"positions": HOME}, "segments": [arc],
                "environment": env}  # fmt: skip
        url = "/v1/trajectories/program"
    err = problem(client.post(url, json=body), 422, "collision")
    assert err["links"][1] == "ball"
    body["environment"] = None  # the same motion without the ball: where was the tool then?
    free = client.post(url, json=body).json()
    tool = _tool_at(free["points"], err["time_from_start"])
    share = _arc_share(tool, p0, interim, goal, center)
    assert 0.1 < share < 0.5
    assert err["s"] == pytest.approx(share, abs=0.01)
