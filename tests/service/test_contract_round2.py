"""API.md promises checked line by line (round 2): partial plans report the clearance of what they
return, and a validation error's ``loc`` names the request's own field (no discriminated-union tags,
the later of two exclusive fields rather than the whole body)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from robots import registry
from service.schemas.common import Pose
from tests.service.helpers import problem

UR5 = registry.get("ur5")
HOME = UR5.home.tolist()
IDENTITY = [0.0, 0.0, 0.0, 1.0]


def goal_pose(offset) -> dict[str, Any]:
    T = UR5.fk(UR5.home)
    T[:3, 3] += offset
    return Pose.from_matrix(T).model_dump()


def ball_env(offset, radius: float) -> dict[str, Any]:
    center = UR5.fk(UR5.home)[:3, 3] + np.asarray(offset)
    pose = {"position": center.tolist(), "orientation": IDENTITY}
    return {
        "obstacles": [{"name": "ball", "shape": {"type": "sphere", "radius": radius}, "pose": pose}]
    }


PARTIAL_BODIES = {
    "cartesian": (
        "/v1/trajectories/cartesian",
        {"method": "sampled", "goal": {"pose": goal_pose([0.2, 0.0, 0.0])}},
    ),
    "program": (
        "/v1/trajectories/program",
        {"segments": [{"type": "lin", "goal": {"pose": goal_pose([0.2, 0.0, 0.0])}}]},
    ),
}


@pytest.mark.parametrize("kind", sorted(PARTIAL_BODIES))
def test_a_partial_plan_reports_the_clearance_of_its_prefix(client: TestClient, kind: str) -> None:
    """A ball on the line at 0.1 m: with allow_partial the prefix before the contact comes back, and
    its ``min_clearance`` / ``closest`` describe that prefix (was: the whole colliding plan's
    negative distance, at a time after the prefix ends)."""
    url, extra = PARTIAL_BODIES[kind]
    env = ball_env([0.1, 0.0, 0.0], 0.02)
    body = {"robot": "ur5", "start": {"positions": HOME}, "environment": env, **extra}
    problem(client.post(url, json=body), 422, "collision")
    answer = client.post(url, json={**body, "allow_partial": True})
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    diag = doc["diagnostics"]
    assert 0.0 < diag["fraction"] < 1.0
    failure = diag["failure"]  # the 422's own fields, the contact included
    assert failure["code"] == "collision" and failure["links"] == ["wrist_3_link", "ball"]
    assert failure["distance"] <= 0 and failure["time_from_start"] > 0
    times = np.array([p["time_from_start"] for p in doc["points"]])
    assert diag["duration"] == pytest.approx(times[-1], abs=1e-12)
    velocities = np.array([p["velocities"] for p in doc["points"]])
    if kind == "cartesian":
        np.testing.assert_allclose(
            np.abs(velocities).max(axis=0), diag["peak_velocity"], atol=1e-12
        )
    else:  # a program's peaks are its analytic q(t)'s (API.md), never below the returned points'
        peak = np.array(diag["peak_velocity"])
        assert np.all(peak >= np.abs(velocities).max(axis=0) - 1e-12)
        assert np.all(peak <= UR5.velocity_limits * (1 + 1e-9))
    assert diag["warnings"][0].startswith("planned ")
    # re-planned to rest before the contact (was cut at 0.77 rad/s; a program was cut moving
    # until the progfix branch), on the line
    np.testing.assert_allclose(velocities[-1], 0.0, atol=1e-12)
    assert not any("ends moving" in w for w in diag["warnings"])
    p0 = UR5.fk(UR5.home)[:3, 3]
    for point in doc["points"]:
        d = UR5.fk(np.asarray(point["positions"]))[:3, 3] - p0
        assert abs(d[1]) <= 1e-3 and abs(d[2]) <= 1e-3 and -1e-3 <= d[0] <= 0.2
    if kind == "cartesian":  # measured on the prefix, not the whole plan
        assert diag["deviation_profile"]["time_from_start"][-1] == times[-1]
    else:  # no segment window past the end of the answer
        assert doc["segments"][-1]["end_time"] == times[-1]
        assert all(s["end_time"] <= times[-1] for s in doc["segments"])
    assert 0.0 <= diag["closest"]["time_from_start"] <= times[-1] + 1e-12
    # an independent distance query at every returned point of the prefix
    distances = [
        client.post(
            "/v1/robots/ur5/distance", json={"positions": p["positions"], "environment": env}
        ).json()["min_distance"]
        for p in doc["points"]
    ]
    assert 0.0 <= diag["min_clearance"] <= min(distances) + 1e-9
    k = int(np.argmin(distances))
    if diag["closest"]["time_from_start"] == pytest.approx(times[k], abs=1e-12):
        # certified: a lower bound of the motion's minimum, within 1e-4 m of it (it was the
        # minimum at the returned points, which the motion between them may undercut)
        assert diag["min_clearance"] == pytest.approx(distances[k], abs=1e-4)


def test_union_members_are_not_in_the_error_location(client: TestClient) -> None:
    """``loc`` is the path in the request: ``segments.0.velocity_scale``, not pydantic's
    ``segments.0.ptp.velocity_scale``; ``shape.size.1``, not ``shape.box.size.1``."""
    body = {
        "robot": "ur5",
        "start": {"positions": HOME},
        "segments": [{"type": "ptp", "goal": {"positions": HOME}, "velocity_scale": 0}],
    }
    err = problem(client.post("/v1/trajectories/program", json=body), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "segments", 0, "velocity_scale"]
    body["segments"] = [{"type": "lin", "goal": {"pose": goal_pose([0.1, 0, 0])}, "bogus": 1}]
    err = problem(client.post("/v1/trajectories/program", json=body), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "segments", 0, "bogus"]
    box = {"name": "b", "shape": {"type": "box", "size": [0.1, -0.1, 0.1]}}
    joint = {
        "robot": "ur5",
        "profile": "quintic",
        "start": {"positions": HOME},
        "goal": {"positions": HOME},
        "duration": 1.0,
        "environment": {"obstacles": [box]},
    }
    err = problem(client.post("/v1/trajectories/joint", json=joint), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "environment", "obstacles", 0, "shape", "size", 1]
    halfspace = {"name": "h", "shape": {"type": "halfspace", "normal": [0, 0, 0], "offset": 0}}
    joint["environment"] = {"obstacles": [halfspace]}
    err = problem(client.post("/v1/trajectories/joint", json=joint), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "environment", "obstacles", 0, "shape", "normal"]
    # an unknown tag is an error at the shape itself
    joint["environment"] = {"obstacles": [{"name": "c", "shape": {"type": "cone"}}]}
    err = problem(client.post("/v1/trajectories/joint", json=joint), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "environment", "obstacles", 0, "shape"]


EXCLUSIVE = {
    "joint": (
        "/v1/trajectories/joint",
        {"profile": "quintic", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]}},
    ),
    "spline": ("/v1/trajectories/spline", {"waypoints": [[0.0], [1.0]], "boundary": "clamped"}),
    "cartesian": (
        "/v1/trajectories/cartesian",
        {
            "robot": "ur5",
            "method": "sampled",
            "start": {"positions": HOME},
            "goal": {"positions": HOME},
        },
    ),
    "program": (
        "/v1/trajectories/program",
        {
            "robot": "ur5",
            "start": {"positions": HOME},
            "segments": [{"type": "ptp", "goal": {"positions": HOME}}],
        },
    ),
}


@pytest.mark.parametrize("kind", sorted(EXCLUSIVE))
def test_samples_with_sample_period_is_422_at_samples(client: TestClient, kind: str) -> None:
    url, body = EXCLUSIVE[kind]
    timed = {"duration": 1.0} if kind in ("joint", "cartesian") else {}
    answer = client.post(url, json={**body, **timed, "samples": 5, "sample_period": 0.1})
    err = problem(answer, 422, "validation")
    assert [e["loc"] for e in err["errors"]] == [["body", "samples"]], err


@pytest.mark.parametrize("speed", ["max_linear_speed", "max_angular_speed"])
def test_duration_with_a_tool_speed_is_422_at_the_speed(client: TestClient, speed: str) -> None:
    url, body = EXCLUSIVE["cartesian"]
    err = problem(client.post(url, json={**body, "duration": 1.0, speed: 0.1}), 422, "validation")
    assert [e["loc"] for e in err["errors"]] == [["body", speed]], err


TWO_LINK = """<robot name="two">
<link name="base_link"/>
<link name="l1">{l1}</link>
<link name="l2">{l2}</link>
<link name="tool0"/>
<joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/><axis xyz="0 0 1"/>
  <limit lower="-3" upper="3" velocity="2" effort="1"/></joint>
<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/>
  <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="2" effort="1"/></joint>
<joint name="jt" type="fixed"><parent link="l2"/><child link="tool0"/><origin xyz="0.5 0 0"/></joint>
</robot>"""
MESH = '<collision><geometry><mesh filename="package://two/l1.stl"/></geometry></collision>'
BOX = '<collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry></collision>'
FAR_BALL = {
    "obstacles": [
        {
            "name": "ball",
            "shape": {"type": "sphere", "radius": 0.1},
            "pose": {"position": [0, 1.5, 0], "orientation": IDENTITY},
        }
    ]
}


def two_link_requests(urdf: str, env: dict[str, Any] | None) -> list[tuple[str, dict[str, Any]]]:
    robot = {"urdf": urdf, "tip_frame": "tool0", "base_frame": "base_link"}
    extra = {} if env is None else {"environment": env}
    return [
        (
            "/v1/trajectories/joint",
            {
                "robot": robot,
                "profile": "quintic",
                "start": {"positions": [0.0, 0.5]},
                "goal": {"positions": [0.5, 1.0]},
                "duration": 1.0,
                **extra,
            },
        ),
        (
            "/v1/trajectories/spline",
            {
                "robot": robot,
                "waypoints": [[0.0, 0.5], [0.5, 1.0]],
                "times": [0.0, 1.0],
                "boundary": "clamped",
                **extra,
            },
        ),
        (
            "/v1/trajectories/cartesian",
            {
                "robot": robot,
                "method": "sampled",
                "start": {"positions": [0.0, 0.5]},
                "goal": {"positions": [0.5, 1.0]},
                **extra,
            },
        ),
        (
            "/v1/trajectories/program",
            {
                "robot": robot,
                "start": {"positions": [0.0, 0.5]},
                "segments": [{"type": "ptp", "goal": {"positions": [0.5, 1.0]}}],
                **extra,
            },
        ),
    ]


@pytest.mark.parametrize("env", [None, FAR_BALL])
def test_mesh_only_links_are_named_in_the_warnings(client: TestClient, env: Any) -> None:
    """API.md: "mesh-only links get a warning that they are not checked": in
    ``diagnostics.warnings`` of every trajectory answer (was only ``collision_warnings``, and only
    with an environment)."""
    for url, body in two_link_requests(TWO_LINK.format(l1=MESH, l2=BOX), env):
        answer = client.post(url, json=body)
        assert answer.status_code == 200, (url, answer.text)
        warnings = answer.json()["diagnostics"]["warnings"]
        assert any("l1" in w and "mesh" in w for w in warnings), (url, warnings)


def test_obstacles_for_a_robot_without_collision_geometry_are_a_warning(client: TestClient) -> None:
    """A robot with no <collision> primitive cannot be checked against obstacles: the answer says
    so (was a silent 200 without min_clearance)."""
    for url, body in two_link_requests(TWO_LINK.format(l1="", l2=""), FAR_BALL):
        answer = client.post(url, json=body)
        assert answer.status_code == 200, (url, answer.text)
        diag = answer.json()["diagnostics"]
        assert "min_clearance" not in diag or diag["min_clearance"] is None
        assert any("no collision geometry" in w for w in diag["warnings"]), (url, diag["warnings"])
    for url, body in two_link_requests(TWO_LINK.format(l1="", l2=""), None):  # nothing asked
        assert client.post(url, json=body).json()["diagnostics"]["warnings"] == [], url
