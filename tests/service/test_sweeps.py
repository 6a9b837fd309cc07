"""Seeded random sweeps across the endpoints: every 200 is re-checked independently of the service.

Each sweep draws requests from a seeded generator (robots, profiles, methods, timings, samplings,
some malformed on purpose) and posts them through the HTTP layer. Never a 5xx; a malformed request
is a 422 problem+json; a well-formed one is a 200 that passes its re-check, or a 422 whose ``code``
is an expected planning outcome for random input (``unreachable``, ``joint_limit``...). A failure
prints the request (the generators are seeded, so it replays).

The re-checks use only the response, the request, the robot's limits as ``GET /v1/robots/{name}``
publishes them and the robot's forward kinematics (pinocchio, in this process):

- every trajectory: the ROS 2 joint trajectory controller's rules (``tests/ros_rules.py``: one value
  per joint, strictly increasing times from 0 to the duration, finite numbers, zero end velocity of
  a rest-to-rest plan), the robot's joint names, the start and goal matched;
- joint-space plans on a robot: every sample inside the position limits, and within the velocity and
  acceleration limits when the service chose the duration (robot-less plans reuse the re-checks of
  ``test_joint_api.py`` / ``test_spline_api.py``: end conditions, scipy's spline, limits binding);
- Cartesian plans: positions inside the limits, speeds within the velocity limits, the tool on the
  line at every returned point (distance and angle from FK; sampled within 1e-6, bounded deviation
  within the tolerance; the rate methods no farther than their diagnostics report), the last pose
  at the goal within the tolerance;
- FK: the pose and Jacobian match pinocchio and a finite-difference Jacobian, the singular values
  match the returned Jacobian; IK: FK of the answer is the requested pose, inside the limits.

The default run posts ``DEFAULT_COUNTS`` (a few hundred requests); the ``slow`` run posts
``SLOW_COUNTS``, at least 10,000 across the endpoints.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from functools import cache
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from core.geometry.so3 import pose_to_matrix
from robots import registry
from service.app import create_app
from service.settings import Settings
from tests.ros_rules import check_ros_trajectory
from tests.service import test_joint_api, test_spline_api

ROBOTS = ("planar_2r", "puma560", "ur5", "panda")
SEED = 20240917
PLANNING_CODES = (
    "unreachable",
    "joint_limit",
    "branch_flip",
    "singularity",
    "joint_rate_limit",
    "infeasible",
    "no_convergence",
    "collision",
)
"""422 codes a well-formed random request may rightly get (the plan is impossible)."""
DEFAULT_COUNTS = {
    "joint": 60,
    "joint_robot": 60,
    "spline": 40,
    "spline_robot": 40,
    "fk": 60,
    "ik": 40,
    "cartesian": 40,
    "compare": 2,
}
SLOW_COUNTS = {
    "joint": 1800,
    "joint_robot": 1800,
    "spline": 1200,
    "spline_robot": 1200,
    "fk": 3000,
    "ik": 2000,
    "cartesian": 500,
    "compare": 20,
}
LIMIT_SLACK = 1e-9
TALLY: dict[str, dict[int, int]] = {}


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(access_log=False))) as test_client:
        yield test_client


@cache
def published(name: str) -> dict[str, Any]:
    """The robot as the API publishes it (joint names, limits, home)."""
    with TestClient(create_app(Settings(access_log=False))) as c:
        return c.get(f"/v1/robots/{name}").json()


def limits(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lim = published(name)["limits"]
    return np.array(lim["position"]), np.array(lim["velocity"]), np.array(lim["acceleration"])


def inside(rng: np.random.Generator, name: str, margin: float = 0.05) -> np.ndarray:
    """A random configuration inside the position limits, ``margin`` of the span from each end."""
    pos, _, _ = limits(name)
    lo, hi = pos[:, 0], pos[:, 1]
    span = np.minimum(hi - lo, 2 * math.pi)
    mid = 0.5 * (lo + hi)
    return rng.uniform(
        np.maximum(lo, mid - span / 2) + margin * span,
        np.minimum(hi, mid + span / 2) - margin * span,
    )


def sampling(rng: np.random.Generator, request: dict[str, Any], small: bool = False) -> None:
    u = rng.random()
    if u < 0.45:
        request["samples"] = int(rng.integers(2, 60 if small else 400))
    elif u < 0.7:
        request["sample_period"] = float(rng.uniform(0.02, 0.2))


def within_limits(name: str, parsed: Any, speeds: bool, accelerations: bool) -> None:
    pos, vel, acc = limits(name)
    span = np.maximum(pos[:, 1] - pos[:, 0], 1.0)
    assert np.all(parsed.positions >= pos[:, 0] - LIMIT_SLACK * span), "below a position limit"
    assert np.all(parsed.positions <= pos[:, 1] + LIMIT_SLACK * span), "above a position limit"
    if speeds:
        assert np.all(np.abs(parsed.velocities) <= vel * (1 + LIMIT_SLACK)), "over a speed limit"
    if accelerations:
        over = np.abs(parsed.accelerations) > acc * (1 + LIMIT_SLACK)
        assert not over.any(), "over an acceleration limit"


# --- joint-space plans on a registered robot --------------------------------------------------


def joint_robot_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    name = str(rng.choice(ROBOTS))
    request: dict[str, Any] = {
        "robot": name,
        "profile": str(rng.choice(test_joint_api.PROFILES)),
        "start": {"positions": inside(rng, name).tolist()},
        "goal": {"positions": inside(rng, name).tolist()},
    }
    if rng.random() < 0.25:
        request["duration"] = float(rng.uniform(0.5, 10.0))
    if rng.random() < 0.2:
        _, vel, _ = limits(name)
        request["limits"] = {"velocity": (vel * rng.uniform(0.2, 1.0, vel.size)).tolist()}
    sampling(rng, request)
    valid = True
    if rng.random() < 0.1:
        valid = False
        broken = int(rng.integers(3))
        if broken == 0:
            request["goal"]["positions"] = request["goal"]["positions"][:-1]
        elif broken == 1:
            request["start"]["positions"][0] = (
                50.0  # outside every joint's limits (422 joint_limit)
            )
        else:
            request["robot"] = "no_such_robot"
    return request, valid


def joint_robot_recheck(request: dict[str, Any], body: dict[str, Any]) -> None:
    name = request["robot"]
    parsed = check_ros_trajectory(body, rest_to_rest=True)
    assert parsed.joint_names == published(name)["joint_names"]
    np.testing.assert_allclose(parsed.positions[0], request["start"]["positions"], atol=1e-9)
    np.testing.assert_allclose(parsed.positions[-1], request["goal"]["positions"], atol=1e-9)
    free = "duration" not in request
    if free and "limits" in request:
        requested = np.array(request["limits"]["velocity"])
        assert np.all(np.abs(parsed.velocities) <= requested * (1 + LIMIT_SLACK))
    within_limits(name, parsed, speeds=free, accelerations=free and request["profile"] != "linear")


# --- splines on a registered robot ------------------------------------------------------------


def spline_robot_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    name = str(rng.choice(ROBOTS))
    count = int(rng.integers(2, 8))
    waypoints = np.array([inside(rng, name, 0.15) for _ in range(count)])
    request: dict[str, Any] = {
        "robot": name,
        "waypoints": waypoints.tolist(),
        "boundary": str(rng.choice(test_spline_api.BOUNDARIES)),
    }
    if rng.random() < 0.25:
        request["times"] = np.concatenate([[0.0], np.cumsum(rng.uniform(1.0, 4.0, count - 1))])
        request["times"] = request["times"].tolist()
    sampling(rng, request)
    valid = True
    if rng.random() < 0.1:
        valid = False
        request["waypoints"][-1] = [*request["waypoints"][-1], 0.0]
    return request, valid


def spline_robot_recheck(request: dict[str, Any], body: dict[str, Any]) -> None:
    name = request["robot"]
    rest = request["boundary"] == "clamped"
    parsed = check_ros_trajectory(body, rest_to_rest=rest)
    assert parsed.joint_names == published(name)["joint_names"]
    knots = body["diagnostics"]["knot_times"]
    index = np.searchsorted(parsed.times, knots)
    hit = index < len(parsed.times)
    hit[hit] &= np.isclose(parsed.times[index[hit]], np.array(knots)[hit], rtol=0, atol=1e-12)
    waypoints = np.array(request["waypoints"])
    np.testing.assert_allclose(parsed.positions[index[hit]], waypoints[hit], atol=1e-9)
    np.testing.assert_allclose(parsed.positions[0], waypoints[0], atol=1e-9)
    np.testing.assert_allclose(parsed.positions[-1], waypoints[-1], atol=1e-9)
    free = "times" not in request
    within_limits(name, parsed, speeds=free, accelerations=free)


def spline_recheck(request: dict[str, Any], body: dict[str, Any]) -> None:
    """``test_spline_api.recheck`` with scipy's rounding allowed for: its reference derivative of
    order k carries about eps x span / T^k of noise (a straight 2-waypoint natural spline timed
    under acceleration limits only has zero acceleration, which scipy gives as 5e-9)."""
    try:
        test_spline_api.recheck(request, body)
        return
    except AssertionError:
        pass
    parsed = check_ros_trajectory(body, rest_to_rest=False)
    knots = body["diagnostics"]["knot_times"]
    ref = test_spline_api.reference(request, knots)
    waypoints = np.array(request["waypoints"], dtype=float)
    span = float(np.ptp(waypoints, axis=0).max()) + 1.0
    duration = knots[-1]
    for order, got in enumerate((parsed.positions, parsed.velocities, parsed.accelerations)):
        want = ref(parsed.times, order)
        noise = 1e-9 * (1 + np.abs(want).max() + span / duration**order)
        np.testing.assert_allclose(got, want, rtol=0, atol=noise, err_msg=f"order {order}")
    np.testing.assert_allclose(ref(knots), waypoints, atol=1e-9)
    for name, column in (("velocity", parsed.velocities), ("acceleration", parsed.accelerations)):
        limit = (request.get("limits") or {}).get(name)
        if "times" not in request and limit is not None:
            assert np.all(np.abs(column) <= np.array(limit) * (1 + 1e-9)), f"over a {name} limit"


# --- forward and inverse kinematics -------------------------------------------------------------


def fk_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    name = str(rng.choice(ROBOTS))
    request = {"robot": name, "body": {"positions": inside(rng, name, 0.0).tolist()}}
    if rng.random() < 0.1:
        request["body"]["positions"].append(0.0)
        return request, False
    return request, True


def fk_recheck(request: dict[str, Any], body: dict[str, Any]) -> None:
    robot = registry.get(request["robot"])
    q = np.array(request["body"]["positions"])
    pose = body["pose"]
    quaternion = np.array(pose["orientation"])
    assert abs(np.linalg.norm(quaternion) - 1.0) <= 1e-12 and quaternion[3] >= 0.0
    T = pose_to_matrix(np.array(pose["position"]), quaternion)
    np.testing.assert_allclose(T, robot.fk(q), atol=1e-12)
    J = np.array(body["jacobian"])
    assert J.shape == (6, robot.dof) and np.all(np.isfinite(J))
    h = 1e-7  # central differences of the forward kinematics: the geometric Jacobian
    for j in range(robot.dof):
        dq = np.zeros(robot.dof)
        dq[j] = h
        Tp, Tm = robot.fk(q + dq), robot.fk(q - dq)
        linear = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        angular = Rotation.from_matrix(Tp[:3, :3] @ Tm[:3, :3].T).as_rotvec() / (2 * h)
        np.testing.assert_allclose(J[:, j], np.concatenate([linear, angular]), atol=1e-6)
    rows = slice(0, 2) if robot.task_space == "position_xy" else slice(0, 6)
    singular = np.linalg.svd(J[rows], compute_uv=False)
    assert body["min_singular_value"] == pytest.approx(singular[-1], abs=1e-12)
    assert body["manipulability"] == pytest.approx(float(np.prod(singular)), abs=1e-12)


def ik_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    name = str(rng.choice(ROBOTS))
    robot = registry.get(name)
    q = inside(rng, name, 0.02)
    T = robot.fk(q)
    quaternion = Rotation.from_matrix(T[:3, :3]).as_quat()
    body: dict[str, Any] = {
        "pose": {"position": T[:3, 3].tolist(), "orientation": quaternion.tolist()}
    }
    if rng.random() < 0.7:  # seeded near the answer, or from the robot's home
        body["seed"] = (q + rng.normal(0.0, 0.2, q.size)).tolist()
    request = {"robot": name, "body": body}
    if rng.random() < 0.1:
        body["pose"]["orientation"] = [0.0, 0.0, 0.0, 0.5]  # norm 0.5: 422
        return request, False
    return request, True


def ik_recheck(request: dict[str, Any], body: dict[str, Any]) -> None:
    name = request["robot"]
    robot = registry.get(name)
    q = np.array(body["positions"])
    assert q.shape == (robot.dof,) and np.all(np.isfinite(q))
    pose = request["body"]["pose"]
    goal = pose_to_matrix(np.array(pose["position"]), np.array(pose["orientation"]))
    T = robot.fk(q)
    if robot.task_space == "position_xy":
        assert np.linalg.norm(T[:2, 3] - goal[:2, 3]) <= 1e-6
    else:
        assert np.linalg.norm(T[:3, 3] - goal[:3, 3]) <= 1e-6
        assert Rotation.from_matrix(T[:3, :3].T @ goal[:3, :3]).magnitude() <= 1e-6
    assert body["position_error"] <= 1e-6 and body["orientation_error"] <= 1e-6
    pos, _, _ = limits(name)
    assert np.all(q >= pos[:, 0] - 1e-9) and np.all(q <= pos[:, 1] + 1e-9), "IK outside the limits"


# --- Cartesian straight lines ------------------------------------------------------------------

METHOD_WEIGHTS = {
    "sampled": 0.3,
    "bounded_deviation": 0.25,
    "bounded_deviation_nlp": 0.05,
    "resolved_rate": 0.2,
    "resolved_rate_dls": 0.2,
}


def cartesian_task(rng: np.random.Generator) -> dict[str, Any]:
    name = str(rng.choice(ROBOTS))
    pos, _, _ = limits(name)
    start = inside(rng, name, 0.1)
    step = rng.normal(0.0, 0.25, start.size)
    goal = np.clip(start + step, pos[:, 0] + 0.02, pos[:, 1] - 0.02)
    task: dict[str, Any] = {"robot": name, "start": {"positions": start.tolist()}}
    if rng.random() < 0.7:
        task["goal"] = {"positions": goal.tolist()}
    else:
        T = registry.get(name).fk(goal)
        q = Rotation.from_matrix(T[:3, :3]).as_quat()
        task["goal"] = {"pose": {"position": T[:3, 3].tolist(), "orientation": q.tolist()}}
    u = rng.random()
    if u < 0.3:
        task["duration"] = float(rng.uniform(1.0, 6.0))
    elif u < 0.6:
        task["max_linear_speed"] = float(rng.uniform(0.05, 0.5))
        task["max_angular_speed"] = float(rng.uniform(0.2, 2.0))
    if rng.random() < 0.3:
        task["tolerance"] = {
            "position": float(10 ** rng.uniform(-4, -2)),
            "orientation": float(10 ** rng.uniform(-3, -1)),
        }
    if rng.random() < 0.2:
        task["allow_partial"] = True
    sampling(rng, task, small=True)
    return task


def cartesian_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    task = cartesian_task(rng)
    methods, weights = zip(*METHOD_WEIGHTS.items(), strict=True)
    task["method"] = str(rng.choice(methods, p=weights))
    if rng.random() < 0.08:
        task["start"]["positions"] = task["start"]["positions"] + [0.0]
        return task, False
    return task, True


def line_errors(request: dict[str, Any], positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] and angle [rad] of the tool from the request's line at each row (the point on
    the line closest by position, the slerp there)."""
    robot = registry.get(request["robot"])
    T0 = robot.fk(np.array(request["start"]["positions"]))
    goal = request["goal"]
    if "positions" in goal:
        T1 = robot.fk(np.array(goal["positions"]))
    else:
        pose = goal["pose"]
        T1 = pose_to_matrix(np.array(pose["position"]), np.array(pose["orientation"]))
    rows = slice(0, 2) if robot.task_space == "position_xy" else slice(0, 3)
    T = robot.fk_many(positions)
    p0, d = T0[rows, 3], T1[rows, 3] - T0[rows, 3]
    s = np.clip((T[:, rows, 3] - p0) @ d / max(d @ d, 1e-300), 0, 1)
    position = np.linalg.norm(T[:, rows, 3] - (p0 + s[:, None] * d), axis=1)
    if robot.task_space == "position_xy":
        return position, np.zeros(len(s))
    R0 = Rotation.from_matrix(T0[:3, :3])
    rotvec = (R0.inv() * Rotation.from_matrix(T1[:3, :3])).as_rotvec()
    R_line = R0 * Rotation.from_rotvec(s[:, None] * rotvec)
    return position, (R_line.inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()


def goal_errors(request: dict[str, Any], q: np.ndarray) -> tuple[float, float]:
    robot = registry.get(request["robot"])
    goal = request["goal"]
    if "positions" in goal:
        T1 = robot.fk(np.array(goal["positions"]))
    else:
        pose = goal["pose"]
        T1 = pose_to_matrix(np.array(pose["position"]), np.array(pose["orientation"]))
    T = robot.fk(q)
    if robot.task_space == "position_xy":
        return float(np.linalg.norm(T[:2, 3] - T1[:2, 3])), 0.0
    angle = Rotation.from_matrix(T[:3, :3].T @ T1[:3, :3]).magnitude()
    return float(np.linalg.norm(T[:3, 3] - T1[:3, 3])), float(angle)


def cartesian_recheck(request: dict[str, Any], body: dict[str, Any], method: str) -> None:
    name = request["robot"]
    parsed = check_ros_trajectory(body, rest_to_rest=True)
    assert parsed.joint_names == published(name)["joint_names"]
    diag = body["diagnostics"]
    assert diag["method"] == method
    np.testing.assert_allclose(parsed.positions[0], request["start"]["positions"], atol=1e-9)
    within_limits(name, parsed, speeds=True, accelerations=False)
    tol = request.get("tolerance", {})
    tol_p, tol_o = tol.get("position", 1e-3), tol.get("orientation", 1e-2)
    position, orientation = line_errors(request, parsed.positions)
    if method == "sampled":
        assert position.max() <= 1e-6 and orientation.max() <= 1e-6, "sampled point off the line"
    elif method.startswith("bounded_deviation"):
        assert position.max() <= tol_p * (1 + 1e-6), "a knot-path point beyond the tolerance"
        assert orientation.max() <= tol_o * (1 + 1e-6), "a knot-path point beyond the tolerance"
    else:  # the rate methods report how far they strayed; never less than at the returned points
        # (position only: the report's closest point weighs orientation too, so its distance is at
        # least this one, the smallest; its angle may be smaller than the angle measured here)
        assert position.max() <= diag["max_position_deviation"] + 1e-9
    fraction = diag["fraction"]
    assert 0.0 < fraction <= 1.0
    if fraction < 1.0:
        assert request.get("allow_partial") and diag["failure"]["code"] in PLANNING_CODES
        return
    ep, eo = goal_errors(request, parsed.positions[-1])
    assert ep <= tol_p * (1 + 1e-6) and eo <= tol_o * (1 + 1e-6), f"end off the goal: {ep}, {eo}"


def compare_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    task = cartesian_task(rng)
    task.pop("allow_partial", None)
    return {"task": task, "include_trajectories": True}, True


def compare_recheck(request: dict[str, Any], body: dict[str, Any]) -> None:
    rows = body["results"]
    assert [row["method"] for row in rows] == list(METHOD_WEIGHTS)
    for row in rows:
        if row["ok"]:
            cartesian_recheck(
                request["task"],
                row["trajectory"] | {"diagnostics": row["diagnostics"]},
                row["method"],
            )
        else:
            assert row["error"]["code"] in PLANNING_CODES, row["error"]


# --- the sweep driver ---------------------------------------------------------------------------

Generator = Callable[[np.random.Generator], tuple[dict[str, Any], bool]]
SWEEPS: dict[str, tuple[str | Callable[[dict[str, Any]], str], Generator, Callable[..., None]]] = {
    "joint": ("/v1/trajectories/joint", test_joint_api.random_request, test_joint_api.recheck),
    "joint_robot": ("/v1/trajectories/joint", joint_robot_request, joint_robot_recheck),
    "spline": ("/v1/trajectories/spline", test_spline_api.random_request, spline_recheck),
    "spline_robot": ("/v1/trajectories/spline", spline_robot_request, spline_robot_recheck),
    "fk": (lambda r: f"/v1/robots/{r['robot']}/fk", fk_request, fk_recheck),
    "ik": (lambda r: f"/v1/robots/{r['robot']}/ik", ik_request, ik_recheck),
    "cartesian": (
        "/v1/trajectories/cartesian",
        cartesian_request,
        lambda req, body: cartesian_recheck(req, body, req["method"]),
    ),
    "compare": ("/v1/compare", compare_request, compare_recheck),
}
TOLERATED = {
    "joint": ("joint_rate_limit",),
    "joint_robot": ("joint_rate_limit", "collision"),
    "spline": (),
    "spline_robot": ("joint_limit", "joint_rate_limit", "collision"),
    "fk": (),
    "ik": ("unreachable", "joint_limit"),
    "cartesian": PLANNING_CODES,
    "compare": (),
}


def run_sweep(client: TestClient, kind: str, count: int, seed: int) -> dict[int, int]:
    url, generate, recheck = SWEEPS[kind]
    rng = np.random.default_rng(seed)
    statuses: dict[int, int] = {}
    for i in range(count):
        request, valid = generate(rng)
        target = url(request) if callable(url) else url
        payload = request["body"] if kind in ("fk", "ik") else request
        response = client.post(target, json=payload)
        statuses[response.status_code] = statuses.get(response.status_code, 0) + 1
        where = f"{kind} request {i} (seed {seed}): POST {target} {json.dumps(payload)}"
        assert response.status_code < 500, f"{where}\n{response.text[:2000]}"
        if response.status_code != 200:
            assert response.status_code in (404, 422), f"{where}\n{response.text[:2000]}"
            assert response.headers["content-type"].startswith("application/problem+json")
            problem = response.json()
            if valid:
                assert problem["code"] in TOLERATED[kind], f"{where}\n{response.text[:2000]}"
            continue
        assert valid, f"{where}: a malformed request was accepted"
        try:
            recheck(request, response.json())
        except AssertionError as err:
            raise AssertionError(f"{where}\n{err}") from err
    TALLY[kind] = {k: TALLY.get(kind, {}).get(k, 0) + v for k, v in statuses.items()}
    return statuses


@pytest.mark.parametrize("kind", list(SWEEPS))
def test_sweep(client: TestClient, kind: str) -> None:
    statuses = run_sweep(client, kind, DEFAULT_COUNTS[kind], SEED)
    assert statuses.get(200, 0) >= 0.5 * DEFAULT_COUNTS[kind], statuses


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(SWEEPS))
def test_sweep_slow(client: TestClient, kind: str) -> None:
    statuses = run_sweep(client, kind, SLOW_COUNTS[kind], SEED + 1)
    assert statuses.get(200, 0) >= 0.5 * SLOW_COUNTS[kind], statuses


def test_slow_sweeps_post_at_least_10000_requests() -> None:
    assert sum(SLOW_COUNTS.values()) >= 10_000
    assert set(SLOW_COUNTS) == set(DEFAULT_COUNTS) == set(SWEEPS)
