"""POST /v1/trajectories/spline through the HTTP layer: equal to scipy's CubicSpline at the returned
times, ROS rules, allocated times within limits, errors, a seeded random sweep, and robots."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.interpolate import CubicSpline

from service.app import create_app
from service.settings import Settings
from tests.ros_rules import check_ros_trajectory
from tests.service.helpers import needs_registry, problem, sweep

URL = "/v1/trajectories/spline"
BOUNDARIES = ("clamped", "natural", "not-a-knot")
SWEEP_SEED = 31337
SWEEP_REQUESTS = 1000
QUICK_SWEEP_REQUESTS = 100
"""The default run's sweep (the first 100 of the same seed, 7 s); `pytest -m slow` runs all 1000."""


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app()) as test_client:
        yield test_client


def spline(boundary: str = "clamped", **extra: Any) -> dict[str, Any]:
    body: dict[str, Any] = {
        "waypoints": [[0.0, 0.0], [1.0, 0.5], [0.5, 1.5], [2.0, 1.0]],
        "boundary": boundary,
        "limits": {"velocity": [1.0, 0.8], "acceleration": [2.0, 3.0]},
    }
    body.update(extra)
    return body


def reference(request: dict[str, Any], knot_times: list[float]) -> CubicSpline:
    q = np.array(request["waypoints"], dtype=float)
    if request["boundary"] == "clamped":
        zeros = [0.0] * q.shape[1]
        v0 = request.get("start_velocity") or zeros
        v1 = request.get("goal_velocity") or zeros
        return CubicSpline(knot_times, q, bc_type=((1, v0), (1, v1)), axis=0)
    return CubicSpline(knot_times, q, bc_type=request["boundary"], axis=0)


def recheck(request: dict[str, Any], body: dict[str, Any], time_format: str = "float") -> None:
    """Every 200: ROS rules, scipy's spline at the returned times, waypoints at the knot times,
    and the limits (respected, binding within 10 %) when the service chose the times."""
    rest = request["boundary"] == "clamped" and not any(request.get("goal_velocity") or [0.0])
    parsed = check_ros_trajectory(body, rest_to_rest=rest, time_format=time_format)
    diag = body["diagnostics"]
    assert diag["method"] == "spline" and diag["boundary"] == request["boundary"]
    knots = diag["knot_times"]
    if "times" in request:
        assert knots == request["times"]
    assert parsed.times[-1] == knots[-1]
    ref = reference(request, knots)
    for order, got in enumerate((parsed.positions, parsed.velocities, parsed.accelerations)):
        want = ref(parsed.times, order)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * (1 + np.abs(want).max()))
    np.testing.assert_allclose(ref(knots), request["waypoints"], atol=1e-9)
    if "times" in request:
        return
    limits = request["limits"]
    dense = np.linspace(0.0, knots[-1], 4001)
    ratios = []
    for name, order, column in (
        ("velocity", 1, parsed.velocities),
        ("acceleration", 2, parsed.accelerations),
    ):
        if limits.get(name) is None:
            continue
        lim = np.array(limits[name])
        assert (np.abs(column).max(axis=0) / lim).max() <= 1 + 1e-9, "a sample exceeds a limit"
        peak = np.abs(ref(np.union1d(dense, knots), order)).max(axis=0)
        ratios.append(peak / lim)
    assert np.concatenate(ratios).max() <= 1 + 1e-9, "the spline exceeds a limit between samples"
    if knots[-1] > 1e-3:
        assert np.concatenate(ratios).max() >= 0.9, "the binding limit is not reached"


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_each_boundary_with_allocated_times(client: TestClient, boundary: str) -> None:
    request = spline(boundary, samples=400)
    response = client.post(URL, json=request)
    assert response.status_code == 200, response.text
    recheck(request, response.json())


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_each_boundary_with_given_times(client: TestClient, boundary: str) -> None:
    request = spline(boundary, times=[0.0, 1.5, 3.5, 6.0], sample_period=0.05)
    del request["limits"]
    if boundary == "clamped":
        request["start_velocity"] = [0.1, -0.2]
    body = client.post(URL, json=request).json()
    recheck(request, body)
    non_rest = boundary != "clamped"
    assert bool(body["diagnostics"]["warnings"]) == non_rest


def test_two_and_three_waypoints(client: TestClient) -> None:
    for boundary in BOUNDARIES:
        for count in (2, 3):
            request = spline(boundary, waypoints=[[0.0], [1.0], [0.0]][:count], samples=50)
            request["limits"] = {"velocity": [1.0], "acceleration": [1.0]}
            response = client.post(URL, json=request)
            assert response.status_code == 200, (boundary, count, response.text)
            recheck(request, response.json())


def test_ros_time_format(client: TestClient) -> None:
    request = spline("clamped", sample_period=0.0137)
    floats = client.post(URL, json=request).json()
    ros = client.post(URL + "?time_format=ros", json=request).json()
    parsed = check_ros_trajectory(ros, rest_to_rest=True, time_format="ros")
    assert parsed.times_ns.tolist() == [round(p["time_from_start"] * 1e9) for p in floats["points"]]


# --- errors: every code this endpoint produces ---


@pytest.mark.parametrize(
    ("change", "loc"),
    [
        (lambda r: r["waypoints"][2].append(0.0), ["body", "waypoints", 2]),
        (lambda r: r.update(waypoints=[[0.0, 0.0]]), ["body", "waypoints"]),
        (lambda r: r.update(times=[0.0, 1.0]), ["body", "times"]),
        (lambda r: r.update(times=[0.5, 1.0, 2.0, 3.0]), ["body", "times", 0]),
        (lambda r: r.update(times=[0.0, 1.0, 1.0, 3.0]), ["body", "times", 2]),
        (lambda r: r.update(times=[0.0, 1.0, 2.0, -3.0]), ["body", "times", 3]),
        (lambda r: r.update(boundary="periodic"), ["body", "boundary"]),
        (
            lambda r: r.update(boundary="natural", goal_velocity=[0.0, 0.0]),
            ["body", "goal_velocity"],
        ),
        (lambda r: r.update(start_velocity=[0.0]), ["body", "start_velocity"]),
        (lambda r: r.pop("limits"), ["body", "limits"]),
        (lambda r: r["limits"].update(acceleration=[1.0]), ["body", "limits", "acceleration"]),
        (lambda r: r.pop("boundary"), ["body", "boundary"]),
    ],
)
def test_validation_names_the_field(client: TestClient, change, loc: list) -> None:
    request = spline()
    change(request)
    body = problem(client.post(URL, json=request), 422, "validation")
    assert body["errors"][0]["loc"] == loc, body


def test_joint_rate_limit(client: TestClient) -> None:
    fast = spline(times=[0.0, 0.1, 0.2, 0.3])
    body = problem(client.post(URL, json=fast), 422, "joint_rate_limit")
    assert "times allocated within the limits would take" in body["detail"]
    body = problem(
        client.post(URL, json=spline(start_velocity=[0.0, 0.9])), 422, "joint_rate_limit"
    )
    assert body["errors"][0]["loc"] == ["body", "start_velocity", 1]


def test_infeasible_and_too_large(client: TestClient) -> None:
    slow = spline(limits={"velocity": [1e-6, 1.0]})
    problem(client.post(URL, json=slow), 422, "infeasible")
    many = spline(times=[0.0, 3e4, 6e4, 1e5], sample_period=1e-3)
    del many["limits"]
    problem(client.post(URL, json=many), 422, "too_large")


def test_time_budget_exceeded() -> None:
    settings = Settings(time_budget_s=1e-9)
    with TestClient(create_app(settings)) as tiny:
        problem(tiny.post(URL, json=spline()), 422, "time_budget_exceeded")


def test_openapi_documents_every_field(client: TestClient) -> None:
    spec = client.get("/openapi.json").json()
    operation = spec["paths"][URL]["post"]
    ok = operation["responses"]["200"]["content"]["application/json"]["schema"]
    refs = sorted(option["$ref"].rsplit("/", 1)[1] for option in ok["anyOf"])
    assert refs == ["ColumnsTrajectoryResponse", "TrajectoryResponse"]  # both ?layout= shapes
    props = spec["components"]["schemas"]["SplineRequest"]["properties"]
    for field, prop in props.items():
        assert prop.get("description"), f"SplineRequest.{field} has no description"
    assert props["waypoints"]["maxItems"] == 10_000 and props["waypoints"]["minItems"] == 2


# --- a seeded random sweep through the HTTP layer ---


def random_request(rng: np.random.Generator) -> tuple[dict[str, Any], bool]:
    dof = int(rng.integers(1, 7))
    count = int(rng.integers(2, 9))
    boundary = str(rng.choice(BOUNDARIES))
    waypoints = rng.uniform(-3, 3, (count, dof))
    if count > 2 and rng.random() < 0.1:
        waypoints[1] = waypoints[0]  # a repeated waypoint
    request: dict[str, Any] = {"waypoints": waypoints.tolist(), "boundary": boundary}
    vmax = rng.uniform(0.3, 3.0, dof)
    if rng.random() < 0.3:
        request["times"] = np.concatenate([[0.0], np.cumsum(rng.uniform(0.2, 3, count - 1))])
        request["times"] = request["times"].tolist()
    else:
        limits = {"velocity": vmax.tolist(), "acceleration": rng.uniform(0.5, 10, dof).tolist()}
        if rng.random() < 0.2:
            limits.pop(str(rng.choice(["velocity", "acceleration"])))
        request["limits"] = limits
    if boundary == "clamped" and rng.random() < 0.3 and "velocity" in request.get("limits", {}):
        request["goal_velocity"] = (vmax * rng.uniform(-0.5, 0.5, dof)).tolist()
    sampling = rng.random()
    if sampling < 0.5:
        request["samples"] = int(rng.integers(2, 300))
    elif sampling < 0.8:
        request["sample_period"] = float(rng.uniform(0.02, 0.3))
    valid = True
    if rng.random() < 0.12:
        valid = False
        broken = int(rng.integers(4))
        if broken == 0:
            request["waypoints"][-1] = request["waypoints"][-1] + [0.0]
        elif broken == 1:
            request["times"] = [0.0] * count
        elif broken == 2:
            request["boundary"] = "natural"
            request["start_velocity"] = [0.1] * dof
        else:
            request["limits"] = {"velocity": [0.0] * dof}
    return request, valid


@pytest.mark.parametrize(
    "count", [QUICK_SWEEP_REQUESTS, pytest.param(SWEEP_REQUESTS, marks=pytest.mark.slow)]
)
def test_random_sweep_never_5xx_and_every_200_rechecked(client: TestClient, count: int) -> None:
    statuses = sweep(client, URL, random_request, recheck, seed=SWEEP_SEED, count=count)
    assert statuses.get(200, 0) >= 0.8 * count, statuses


# --- robots (the registry is another engineer's; these run once it exists) ---


@needs_registry
def test_a_registered_robot(client: TestClient) -> None:
    from robots.registry import resolve

    panda = resolve("panda")
    home = np.asarray(panda.home)
    request = {
        "robot": "panda",
        "waypoints": [home.tolist(), (home + 0.2).tolist(), (home - 0.1).tolist()],
        "boundary": "clamped",
        "samples": 500,
    }
    body = client.post(URL, json=request).json()
    parsed = check_ros_trajectory(body, rest_to_rest=True)
    assert parsed.joint_names == list(panda.joint_names)
    ratio = max(
        (np.abs(parsed.velocities).max(axis=0) / panda.velocity_limits).max(),
        (np.abs(parsed.accelerations).max(axis=0) / panda.acceleration_limits).max(),
    )
    assert 0.85 <= ratio <= 1 + 1e-9  # samples; the exact peak binds (checked in core tests)
    request["waypoints"][1] = [0.0] * 6
    body = problem(client.post(URL, json=request), 422, "validation")
    assert body["errors"][0]["loc"] == ["body", "waypoints", 1]
    request["waypoints"][1] = (home + 50.0).tolist()
    body = problem(client.post(URL, json=request), 422, "joint_limit")
    assert body["errors"][0]["loc"][:3] == ["body", "waypoints", 1]
    problem(client.post(URL, json={**request, "robot": "r2d2"}), 404, "unknown_robot")


def test_a_urdf_speed_limit_of_1e_300_is_a_422_not_a_500(client: TestClient) -> None:
    """Issue 19 item 1: an inline URDF whose velocity limit is 1e-300 rad/s."""
    urdf = (
        '<robot name="tiny"><link name="base"/><link name="tip"/>'
        '<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>'
        '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1e-300"/></joint>'
        "</robot>"
    )
    body = {
        "robot": {"urdf": urdf, "tip_frame": "tip", "base_frame": "base"},
        "waypoints": [[0.0], [0.5]],
        "boundary": "clamped",
        "samples": 5,
    }
    response = client.post("/v1/trajectories/spline", json=body)
    assert response.status_code == 422, response.text
    assert response.json()["code"] in ("invalid_urdf", "infeasible")
