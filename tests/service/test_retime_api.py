"""POST /v1/trajectories/retime and effort limits, through HTTP, against independent references.

- Effort: pinocchio's RNEA recomputed here (its own model, from the robot's URDF) on the answer's
  q, q', q'' at every returned point, within the request's limits (50 % of the maker's) to 1e-6
  relative, and the motion longer than without them.
- The path: every returned point on the geometric path (scipy's CubicSpline in the chord-length
  parameter for ``spline``; the blended path's own lines and arcs, independently sampled).
- Every contract error of the round-3 additions, with its code and field.
"""

from __future__ import annotations

import itertools
import json
from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient
from scipy.interpolate import CubicSpline

from robots import registry
from tests.service.helpers import problem

URL = "/v1/trajectories/retime"
G = np.array([0.0, 0.0, -9.81])


def arrays(body: dict[str, Any]) -> tuple[np.ndarray, ...]:
    points = body["points"]
    return tuple(
        np.array([p[k] for p in points], dtype=float)
        for k in ("time_from_start", "positions", "velocities", "accelerations")
    )


def rnea(name: str, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Inverse dynamics by pinocchio on a model of its own (gravity -z in the base frame, which
    is pinocchio's world frame for the shipped robots)."""
    model = pin.Model(registry.get(name).model)
    data = model.createData()
    return np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd, strict=True)])


MOVES = {
    "panda": [
        [0.0, -0.6, 0.0, -2.2, 0.0, 1.6, 0.8],
        [0.8, -0.2, 0.3, -1.8, 0.2, 1.9, 0.5],
        [1.4, 0.3, 0.0, -1.2, -0.3, 2.2, 1.0],
    ],
    "ur5": [
        [0.0, -1.2, 1.4, -1.5, -1.5, 0.0],
        [0.6, -1.6, 1.2, -1.2, -1.2, 0.5],
        [1.2, -1.9, 0.9, -1.0, -1.0, 1.0],
    ],
}


@pytest.mark.parametrize("name", sorted(MOVES))
@pytest.mark.parametrize("path", ["blended", "spline"])
def test_effort_at_half_the_makers_limits(client: TestClient, name: str, path: str) -> None:
    robot = registry.get(name)
    half = (0.5 * robot.effort_limits).tolist()
    fast = (robot.acceleration_limits * 20).tolist()
    body = {"robot": name, "waypoints": MOVES[name], "path": path, "sample_period": 0.002}
    free = client.post(URL, json={**body, "limits": {"acceleration": fast}})
    held = client.post(URL, json={**body, "limits": {"acceleration": fast, "effort": half}})
    assert free.status_code == 200 and held.status_code == 200, held.text
    _, q, qd, qdd = arrays(held.json())
    tau = rnea(name, q, qd, qdd)
    assert (np.abs(tau) / half).max() <= 1.0 + 1e-6
    d_free, d_held = free.json()["diagnostics"], held.json()["diagnostics"]
    assert d_held["duration"] > d_free["duration"]
    assert "effort" in {b["limit"] for b in d_held["binding"]}
    assert np.all(np.array(d_held["peak_effort"]) >= np.abs(tau).max(axis=0) - 1e-9)
    assert np.all(np.array(d_held["peak_effort"]) <= np.array(half) * (1 + 1e-6))


def test_effort_on_joint_and_spline_endpoints(client: TestClient) -> None:
    robot = registry.get("panda")
    half = (0.5 * robot.effort_limits).tolist()
    fast = (robot.acceleration_limits * 20).tolist()
    quick = (robot.velocity_limits * 3).tolist()
    start, goal = MOVES["panda"][0], MOVES["panda"][2]
    for url, body in (
        ("/v1/trajectories/joint", {"profile": "quintic", "start": {"positions": start},
                                    "goal": {"positions": goal}}),
        ("/v1/trajectories/spline", {"waypoints": MOVES["panda"], "boundary": "clamped"}),
    ):  # fmt: skip
        base = {"robot": "panda", "samples": 2000, **body}
        limits = {"acceleration": fast, "velocity": quick}
        free = client.post(url, json={**base, "limits": limits})
        held = client.post(url, json={**base, "limits": {**limits, "effort": half}})
        assert held.status_code == 200, held.text
        _, q, qd, qdd = arrays(held.json())
        assert (np.abs(rnea("panda", q, qd, qdd)) / half).max() <= 1.0 + 1e-6
        assert held.json()["diagnostics"]["duration"] > free.json()["diagnostics"]["duration"]
        assert len(free.json()["diagnostics"]["peak_effort"]) == 7
    fixed = {"robot": "panda", "profile": "quintic", "start": {"positions": start},
             "goal": {"positions": goal}, "duration": 3.0, "limits": {"effort": half}}  # fmt: skip
    error = problem(client.post("/v1/trajectories/joint", json=fixed), 422, "validation")
    assert error["errors"][0]["loc"][-2:] == ["limits", "effort"]


@pytest.mark.parametrize("path", ["spline", "blended"])
def test_points_lie_on_the_path_and_limits_hold(client: TestClient, path: str) -> None:
    rng = np.random.default_rng(3)
    waypoints = np.cumsum(rng.uniform(-0.4, 0.4, (12, 3)), axis=0)
    v, a = [1.0, 1.5, 2.0], [3.0, 4.0, 5.0]
    body = {
        "waypoints": waypoints.tolist(),
        "path": path,
        "limits": {"velocity": v, "acceleration": a},
    }
    response = client.post(URL, json=body)
    assert response.status_code == 200, response.text
    answer = response.json()
    _t, q, qd, qdd = arrays(answer)
    assert np.all(np.abs(qd) <= np.array(v) * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= np.array(a) * (1 + 1e-9))
    np.testing.assert_array_equal(qd[[0, -1]], 0.0)
    chords = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    knots = np.concatenate([[0.0], np.cumsum(chords)])
    if path == "spline":  # the distance to scipy's spline, minimized around the nearest sample
        spline = CubicSpline(knots, waypoints, bc_type="not-a-knot")
        s = np.linspace(0, knots[-1], 200_001)
        dense = spline(s)
        gaps = []
        for p in q[:: max(1, len(q) // 200)]:
            x = s[int(np.linalg.norm(dense - p, axis=1).argmin())]
            for _ in range(8):  # Newton on (q(x) - p) . q'(x) = 0: the foot of the normal
                r, d1, d2 = spline(x) - p, spline(x, 1), spline(x, 2)
                x = float(np.clip(x - r @ d1 / (d1 @ d1 + r @ d2), 0.0, knots[-1]))
            gaps.append(float(np.linalg.norm(spline(x) - p)))
        assert max(gaps) <= 1e-9
    else:  # the straight segments, sampled independently: the path is within 0.1 of them
        dense = np.concatenate(
            [np.linspace(p, r, 20_001) for p, r in itertools.pairwise(waypoints)]
        )
        gaps = [np.linalg.norm(dense - p, axis=1).min() for p in q[:: max(1, len(q) // 300)]]
        assert max(gaps) <= 0.1 + 1e-4  # max_deviation, plus the sampling of the segments
    diag = answer["diagnostics"]
    assert diag["timing"] == "time_optimal" and diag["path_length"] > 0.0
    assert diag["binding"][0]["s"][0] == 0.0 and diag["binding"][-1]["s"][1] == 1.0
    assert diag["peak_acceleration"] == pytest.approx(np.abs(qdd).max(axis=0), rel=1e-3)


def test_accelerations_integrate_to_the_velocities(client: TestClient) -> None:
    waypoints = [[0.0, 0.0], [1.0, 0.4], [1.5, -0.3], [2.5, 0.2]]
    body = {"waypoints": waypoints, "limits": {"velocity": [1, 1], "acceleration": [2, 3]},
            "sample_period": 0.0005}  # fmt: skip
    t, _, qd, qdd = arrays(client.post(URL, json=body).json())
    trapezoid = 0.5 * (qdd[1:] + qdd[:-1]) * np.diff(t)[:, None]
    assert np.abs(trapezoid - np.diff(qd, axis=0)).max() <= 1e-6


def test_jerk_limits_on_a_spline(client: TestClient) -> None:
    """With limits.jerk: the returned accelerations' slopes (finite differences, an independent
    estimate of the jerk) within it, velocity and acceleration within theirs, acceleration
    continuous from rest to rest, the trapezoid rule of the accelerations giving the velocities,
    and the motion no shorter than the time-optimal one of the same request without jerk."""
    waypoints = [[0.0, 0.0, 0.0], [0.6, 0.3, -0.2], [1.0, -0.2, 0.1], [1.5, 0.4, 0.3]]
    v, a, j = [1.0, 1.5, 2.0], [3.0, 4.0, 5.0], [20.0, 30.0, 40.0]
    body = {"waypoints": waypoints, "path": "spline", "sample_period": 0.0005,
            "limits": {"velocity": v, "acceleration": a}}  # fmt: skip
    optimal = client.post(URL, json=body).json()["diagnostics"]
    response = client.post(URL, json={**body, "limits": {**body["limits"], "jerk": j}})
    assert response.status_code == 200, response.text
    answer = response.json()
    t, _, qd, qdd = arrays(answer)
    slopes = np.abs(np.diff(qdd, axis=0)) / np.diff(t)[:, None]
    assert (slopes / np.array(j)).max() <= 1.0 + 1e-6
    assert (np.abs(qd) / np.array(v)).max() <= 1.0 + 1e-9
    assert (np.abs(qdd) / np.array(a)).max() <= 1.0 + 1e-9
    np.testing.assert_allclose(qdd[[0, -1]], 0.0, atol=1e-9)
    trapezoid = 0.5 * (qdd[1:] + qdd[:-1]) * np.diff(t)[:, None]
    assert np.abs(trapezoid - np.diff(qd, axis=0)).max() <= 1e-6
    diag = answer["diagnostics"]
    assert diag["timing"] == "jerk_limited"
    assert diag["time_optimal_duration"] == pytest.approx(optimal["duration"], rel=1e-9)
    assert diag["duration"] >= optimal["duration"]
    assert np.all(np.array(diag["peak_jerk"]) <= np.array(j) * (1 + 1e-9))
    assert np.all(np.array(diag["peak_jerk"]) >= slopes.max(axis=0) * (1 - 1e-6))


def test_tool_speed_limits(client: TestClient) -> None:
    body = {"robot": "ur5", "waypoints": MOVES["ur5"], "max_linear_speed": 0.3,
            "max_angular_speed": 0.8, "sample_period": 0.002}  # fmt: skip
    answer = client.post(URL, json=body).json()
    _, q, qd, _ = arrays(answer)
    robot = registry.get("ur5")
    v = np.einsum("kij,kj->ki", robot.jacobian_many(q), qd)
    assert np.linalg.norm(v[:, :3], axis=1).max() <= 0.3 * (1 + 1e-6)
    assert np.linalg.norm(v[:, 3:], axis=1).max() <= 0.8 * (1 + 1e-6)


def test_tool_speed_limits_hold_at_the_tool_offset(client: TestClient) -> None:
    """With ``tool`` the linear speed limit holds at the tool point (by pinocchio here: the tip's
    velocity plus omega x the offset), which moves faster than the tip on this wrist-heavy move;
    the same limit at the tip is a shorter motion."""
    offset = [0.0, 0.0, 0.25]
    body = {"robot": "ur5", "waypoints": MOVES["ur5"], "max_linear_speed": 0.3,
            "sample_period": 0.002}  # fmt: skip
    with_tool = client.post(
        URL, json=body | {"tool": {"position": offset, "orientation": [0, 0, 0, 1]}}
    ).json()
    without = client.post(URL, json=body).json()
    assert with_tool["diagnostics"]["duration"] > without["diagnostics"]["duration"]
    _, q, qd, _ = arrays(with_tool)
    robot = registry.get("ur5")
    model, data = robot.model, robot.model.createData()
    frame = model.getFrameId(robot.tip_frame)
    speed = []
    for qi, vi in zip(q, qd, strict=True):
        pin.computeJointJacobians(model, data, qi)
        pin.framesForwardKinematics(model, data, qi)
        J = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
        twist = J @ vi
        lever = data.oMf[frame].rotation @ np.array(offset)
        speed.append(np.linalg.norm(twist[:3] + np.cross(twist[3:], lever)))
    assert max(speed) <= 0.3 * (1 + 1e-6)
    assert max(speed) >= 0.3 * (1 - 1e-3)  # the limit binds somewhere


def test_robot_description_reports_dynamics(client: TestClient) -> None:
    ur5 = client.get("/v1/robots/ur5").json()
    assert ur5["dynamics"] is True and ur5["limits"]["effort"] == [150.0] * 3 + [28.0] * 3
    planar = client.get("/v1/robots/planar_2r").json()
    assert planar["dynamics"] is True and planar["limits"]["effort"] is None


LIMITS = {"velocity": [1.0, 1.0], "acceleration": [2.0, 2.0]}


@pytest.mark.parametrize(
    ("body", "status", "code", "loc"),
    [
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]] * 5001, "limits": LIMITS}, 422, "validation",
         ["body", "waypoints"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]], "limits": LIMITS}, 422, "validation",
         ["body", "waypoints", 2]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": {**LIMITS, "effort": [1.0, 1.0]}}, 422,
         "validation", ["body", "limits", "effort"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": {"velocity": [1.0, 1.0]}}, 422,
         "validation", ["body", "limits", "acceleration"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": LIMITS, "max_linear_speed": 1.0}, 422,
         "validation", ["body", "max_linear_speed"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": LIMITS,
          "tool": {"position": [0, 0, 0.1], "orientation": [0, 0, 0, 1]}}, 422, "validation",
         ["body", "tool"]),
        # jerk limits need a spline (a blended path's curvature steps)
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": {**LIMITS, "jerk": [1.0, 1.0]}}, 422,
         "validation", ["body", "limits", "jerk"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "path": "spline",
          "limits": {**LIMITS, "jerk": [1.0, -1.0]}}, 422, "validation", ["body", "limits", "jerk"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": LIMITS, "path": "spline",
          "max_deviation": 0.2}, 422, "validation", ["body", "max_deviation"]),
        ({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": LIMITS, "gravity": [0, 0, -9.81]}, 422,
         "validation", ["body", "gravity"]),
        ({"waypoints": [[0.0, 0.0], [1.0]], "limits": LIMITS}, 422, "validation",
         ["body", "waypoints", 1]),
    ],
)  # fmt: skip
def test_contract_errors(
    client: TestClient, body: dict[str, Any], status: int, code: str, loc: list[Any]
) -> None:
    error = problem(client.post(URL, json=body), status, code)
    assert error["errors"][0]["loc"][: len(loc)] == loc


def test_nan_is_refused(client: TestClient) -> None:
    text = json.dumps({"waypoints": [[0.0, 0.0], [1.0, 0.0]], "limits": LIMITS})
    text = text.replace("1.0, 0.0]]", "NaN, 0.0]]")
    response = client.post(URL, content=text, headers={"content-type": "application/json"})
    error = problem(response, 422, "validation")
    assert error["errors"][0]["loc"][:3] == ["body", "waypoints", 1]


def test_effort_on_a_robot_without_dynamics(client: TestClient) -> None:
    urdf = registry.get("planar_2r")  # a URDF without inertials: the planar arm's, stripped
    text = (
        '<robot name="bare"><link name="base_link"/><link name="a"/><link name="b"/>'
        '<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/>'
        '<axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="5"/></joint>'
        '<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/>'
        '<axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="5"/></joint></robot>'
    )
    assert urdf.dof == 2
    body = {"robot": {"urdf": text}, "waypoints": [[0.0, 0.0], [1.0, 0.5]],
            "limits": {"effort": [5.0, 5.0]}}  # fmt: skip
    error = problem(client.post(URL, json=body), 422, "validation")
    assert error["errors"][0]["loc"] == ["body", "limits", "effort"]
    described = client.post("/v1/robots/describe", json={"robot": {"urdf": text}}).json()
    assert described["dynamics"] is False and described["limits"]["effort"] == [5.0, 5.0]


def test_gravity_alone_above_an_effort_limit(client: TestClient) -> None:
    body = {"robot": "ur5", "waypoints": MOVES["ur5"],
            "limits": {"effort": [150.0, 10.0, 150.0, 28.0, 28.0, 28.0]}}  # fmt: skip
    error = problem(client.post(URL, json=body), 422, "infeasible")
    assert error["joint"] == 1 and "shoulder_lift_joint" in error["detail"]
    assert 0.0 <= error["s"] <= 1.0
