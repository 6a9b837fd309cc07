"""The client against a live service: every method's typed result equals the service's own JSON
answer (read independently with httpx), numpy results equal the lists, and each family of failure
raises its exception carrying the problem body."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
import pytest
from trajectory_client import (
    Comparison,
    InvalidRequest,
    NotFound,
    PlanningFailed,
    Pose,
    TrajectoryClient,
)

from bench.batch import ENVIRONMENT, UR5_HOME, UR5_TOOL_DOWN, joint_moves, lines

JOINT = {
    "profile": "quintic",
    "start": {"positions": [0.0, 0.0]},
    "goal": {"positions": [1.0, 0.5]},
    "duration": 2.0,
    "samples": 7,
}
SPLINE = {
    "waypoints": [[0.0, 0.0], [1.0, 0.2], [0.5, 0.4]],
    "boundary": "clamped",
    "limits": {"velocity": [1.0, 1.0], "acceleration": [2.0, 2.0]},
}
PROGRAM = {
    "robot": "ur5",
    "start": {"positions": UR5_HOME},
    "segments": [
        {"type": "lin", "goal": {"pose": {"position": [-0.6, -0.1, 0.25], "orientation": UR5_TOOL_DOWN}}},
        {"type": "ptp", "goal": {"positions": UR5_HOME}},
    ],
}  # fmt: skip
RETIME = {
    "waypoints": [[0.0, 0.0], [1.0, 0.4], [1.5, -0.3]],
    "limits": {"velocity": [1.0, 1.0], "acceleration": [2.0, 3.0]},
    "sample_period": 0.05,
}
COLLISION_FREE = {
    "robot": "ur5",
    "start": {"positions": UR5_HOME},
    "goal": {"positions": [1.2, -1.0471975511965976, 1.5707963267948966, -2.0943951023931953,
                           -1.5707963267948966, 0.0]},
    "environment": {"obstacles": [{"name": "post", "shape": {"type": "box", "size": [0.1, 0.1, 0.6]},
                                   "pose": {"position": [-0.3, -0.45, 0.3], "orientation": [0, 0, 0, 1]}}]},
    "seed": 3,
}  # fmt: skip
PLANAR_TASK = {
    "robot": "planar_2r",
    "start": {"positions": [0.3, 1.2]},
    "goal": {"pose": {"position": [1.79, 0.0, 0.0], "orientation": [0, 0, 0, 1]}},
    "duration": 2.5,
}


@pytest.fixture(scope="module")
def client(service_url: str) -> Any:
    with TrajectoryClient(service_url, timeout=60) as c:
        yield c


def raw(url: str, path: str, body: Any = None) -> Any:
    """The service's own answer, read without the client."""
    if body is None:
        return httpx.get(url + path, timeout=60).json()
    return httpx.post(url + path, json=body, timeout=60).json()


def test_health_ready_and_robots(client: TrajectoryClient, service_url: str) -> None:
    assert client.health().version == raw(service_url, "/health")["version"]
    assert client.ready().robots == ["panda", "planar_2r", "puma560", "ur5"]
    rows = client.robots()
    assert [r.name for r in rows] == [r["name"] for r in raw(service_url, "/v1/robots")]
    ur5 = client.robot("ur5")
    assert ur5.dof == 6 and ur5.home == raw(service_url, "/v1/robots/ur5")["home"]
    assert ur5.limits is not None and len(ur5.limits["velocity"]) == 6
    described = client.describe("planar_2r")
    assert described.task_space == "position_xy" and described.raw["ik"]["solver"] == "analytic"


def test_fk_ik_and_distance(client: TrajectoryClient, service_url: str) -> None:
    fk = client.fk("planar_2r", [0.0, 0.0])
    assert fk.pose.position == pytest.approx([1.8, 0.0, 0.0], abs=1e-12)  # links of 1 and 0.8 m
    assert fk.raw == raw(service_url, "/v1/fk", {"robot": "planar_2r", "positions": [0.0, 0.0]})
    pose = Pose([1.0, 0.8, 0.0], [0.0, 0.0, 0.0, 1.0])
    one = client.ik("planar_2r", pose)
    every = client.ik("planar_2r", pose.to_json(), all=True)
    assert len(every.solutions) == 2 and {s.configuration for s in every.solutions} == {
        "up",
        "down",
    }
    assert one.positions in [s.positions for s in every.solutions]
    for solution in every.solutions:  # each one reaches the pose
        reached = client.fk("planar_2r", np.array(solution.positions))
        assert reached.pose.position[:2] == pytest.approx([1.0, 0.8], abs=1e-9)
    near = client.distance("ur5", UR5_HOME, environment=ENVIRONMENT)
    reference = raw(service_url, "/v1/distance", {"robot": "ur5", "positions": UR5_HOME, "environment": ENVIRONMENT})  # fmt: skip
    assert near.min_distance == reference["min_distance"] and near.pairs == reference["pairs"]


def assert_same_trajectory(plan: Any, answer: dict[str, Any]) -> None:
    """A typed trajectory against the service's ROS-shaped answer."""
    points = answer["points"]
    assert plan.joint_names == answer["joint_names"]
    assert np.array_equal(np.asarray(plan.time_from_start), [p["time_from_start"] for p in points])
    for column in ("positions", "velocities", "accelerations"):
        assert np.array_equal(np.asarray(getattr(plan, column)), [p[column] for p in points])
    assert plan.duration == answer["diagnostics"]["duration"]


@pytest.mark.parametrize(
    ("method", "path", "body"),
    [
        ("joint", "/v1/trajectories/joint", JOINT),
        ("spline", "/v1/trajectories/spline", SPLINE),
        ("cartesian", "/v1/trajectories/cartesian", lines(1)[0]),
        ("program", "/v1/trajectories/program", PROGRAM),
        ("joint", "/v1/trajectories/joint", joint_moves(1)[0]),
        ("retime", "/v1/trajectories/retime", RETIME),
        ("collision_free", "/v1/trajectories/collision_free", COLLISION_FREE),
    ],
)
def test_trajectories_as_lists_and_as_numpy(
    client: TrajectoryClient, service_url: str, method: str, path: str, body: dict[str, Any]
) -> None:
    answer = raw(service_url, path, body)
    as_lists = getattr(client, method)(body)
    assert isinstance(as_lists.positions, list)
    assert_same_trajectory(as_lists, answer)
    as_arrays = getattr(client, method)(**body, as_numpy=True)
    n, dof = len(answer["points"]), len(answer["joint_names"])
    assert as_arrays.positions.shape == (n, dof) and as_arrays.positions.dtype == np.float64
    assert as_arrays.time_from_start.shape == (n,)
    assert_same_trajectory(as_arrays, answer)
    assert as_lists.points() == answer["points"]
    if method == "program":
        assert as_lists.raw["segments"] == answer["segments"]
    if method == "collision_free":
        assert as_lists.raw["waypoints"] == answer["waypoints"]
        assert as_lists.diagnostics["planner"]["seed"] == 3


def test_compare(client: TrajectoryClient) -> None:
    result = client.compare(task=PLANAR_TASK, methods=["sampled", "bounded_deviation"],
                            include_trajectories=True, as_numpy=True)  # fmt: skip
    assert isinstance(result, Comparison)
    assert [r.method for r in result.rows] == ["sampled", "bounded_deviation"]
    for row in result.rows:
        assert row.ok and row.error is None and row.trajectory is not None
        assert row.trajectory.positions.shape[1] == 2
    rushed = client.compare(task={**PLANAR_TASK, "duration": 0.5}, methods=["sampled"])
    row = rushed.rows[0]  # too fast for the joints: the row's failure, as an exception
    assert not row.ok and isinstance(row.error, PlanningFailed)
    assert row.error.code == row.diagnostics["code"] == "joint_rate_limit"


def test_a_422_with_s_is_planning_failed(client: TrajectoryClient) -> None:
    far = {**PLANAR_TASK, "method": "sampled", "goal": {"pose": {"position": [0.05, 0.0, 0.0], "orientation": [0, 0, 0, 1]}}}  # fmt: skip
    with pytest.raises(PlanningFailed) as caught:
        client.cartesian(far)
    err = caught.value
    assert (err.status, err.code) == (422, "unreachable") and 0 < err.s < 1
    assert err.body["code"] == "unreachable" and err.body["s"] == err.s and err.segment is None


def test_a_failing_program_segment_is_named(client: TrajectoryClient) -> None:
    away = {"type": "lin", "goal": {"pose": {"position": [-2.0, -0.1, 0.25], "orientation": UR5_TOOL_DOWN}}}  # fmt: skip
    with pytest.raises(PlanningFailed) as caught:
        client.program(PROGRAM, segments=[PROGRAM["segments"][0], away])
    assert caught.value.segment == 1 and caught.value.code == "unreachable"


def test_validation_404_and_413(client: TrajectoryClient) -> None:
    with pytest.raises(InvalidRequest) as caught:
        client.joint(JOINT, goal={"positions": [1.0]})
    assert caught.value.status == 422 and caught.value.code == "validation"
    assert caught.value.errors[0]["loc"][:2] == ["body", "goal"]
    with pytest.raises(NotFound) as missing:
        client.fk("no_such_robot", [0.0])
    assert missing.value.code == "unknown_robot" and "ur5" in missing.value.body["available"]
    with pytest.raises(NotFound):
        client.robot("no_such_robot")
    huge = {"urdf": "<robot name='x'>" + " " * (2 * 1024 * 1024) + "</robot>"}
    with pytest.raises(InvalidRequest) as too_large:
        client.fk(huge, [0.0])
    assert (too_large.value.status, too_large.value.code) == (413, "too_large")


def test_nan_is_refused_before_sending(client: TrajectoryClient) -> None:
    with pytest.raises(ValueError, match="JSON"):
        client.joint(JOINT, duration=float("nan"))


def test_the_raw_request_and_the_context_manager(service_url: str) -> None:
    with TrajectoryClient(service_url, timeout=httpx.Timeout(30.0)) as c:
        answer = c.request("POST", "/v1/trajectories/joint", JOINT, {"time_format": "ros"})
        assert answer["points"][-1]["time_from_start"] == {"sec": 2, "nanosec": 0}
    assert c._http.is_closed
