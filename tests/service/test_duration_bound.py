"""Issue 26.2: no time runs backwards. Every duration a request gives or implies is bounded by
``MAX_DURATION`` (1e5 s): a field that is a duration is 422 ``validation`` past it, and a plan that
some other field stretches past it (tiny scales, speeds, limits) is 422 ``infeasible`` naming
``max_duration``; ``?time_format=ros`` can then neither overflow nor go backwards. The shortest
feasible duration is ``min_duration`` in every problem body that states one."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from core.errors import Infeasible
from core.trajectory import MAX_DURATION, Trajectory
from service.encoding import check_finite, ros_durations
from service.points_json import points_json
from tests.service.helpers import needs_registry, problem

UR5_HOME = [0.0, -1.5, 1.5, -1.5, -1.5, 0.0]
UR5_TURN = [1.0, -1.5, 1.5, -1.5, -1.5, 0.0]


def _ros_seconds(points: list[dict]) -> np.ndarray:
    """The returned ROS times as exact seconds (Python ints: no float rounding on the way)."""
    stamps = [p["time_from_start"] for p in points]
    assert all(0 <= s["nanosec"] < 1_000_000_000 and s["sec"] >= 0 for s in stamps), stamps[:3]
    return np.array([s["sec"] * 1_000_000_000 + s["nanosec"] for s in stamps], dtype=object)


def test_ros_times_at_the_bound_are_exact_and_increasing(client) -> None:
    """The longest allowed plan in ROS format: last point at exactly 1e5 s, times increasing."""
    body = {
        "profile": "quintic",
        "start": {"positions": [0.0]},
        "goal": {"positions": [1.0]},
        "duration": MAX_DURATION,
        "samples": 7,
    }
    answer = client.post("/v1/trajectories/joint?time_format=ros", json=body)
    assert answer.status_code == 200, answer.text
    ns = _ros_seconds(answer.json()["points"])
    assert ns[-1] == int(MAX_DURATION) * 1_000_000_000
    assert all(b > a for a, b in itertools.pairwise(ns))


def test_the_ros_conversion_refuses_what_it_cannot_hold() -> None:
    """9.3e9 s wrapped to sec -9223372037 before; now the conversion refuses it (both encoders)."""
    for times in (np.array([0.0, 9.3e9]), np.array([-1.0, 0.0]), np.array([0.0, 2e5])):
        with pytest.raises(Infeasible):
            ros_durations(times)
        zeros = np.zeros((2, 1))
        with pytest.raises(Infeasible):
            points_json(Trajectory(times, zeros, zeros, zeros), "ros")


def test_no_trajectory_longer_than_the_bound_is_returned() -> None:
    """The exit check every trajectory route passes: a plan of 2e5 s is refused with its numbers."""
    zeros = np.zeros((2, 1))
    with pytest.raises(Infeasible) as err:
        check_finite(Trajectory(np.array([0.0, 2e5]), zeros, zeros, zeros))
    assert err.value.extra == {"duration": 2e5, "max_duration": MAX_DURATION}


@pytest.mark.parametrize(
    ("url", "body", "field"),
    [
        (
            "/v1/trajectories/joint",
            {"profile": "cubic", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]},
             "duration": 1.0000001e5},
            "duration",
        ),
        (
            "/v1/trajectories/joint",
            {"profile": "cubic", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]},
             "duration": 1.0, "sample_period": 1.5e5},
            "sample_period",
        ),
        (
            "/v1/trajectories/spline",
            {"waypoints": [[0.0], [1.0]], "times": [0.0, 2e5], "boundary": "natural"},
            "times",
        ),
    ],
)  # fmt: skip
def test_a_duration_field_past_the_bound_is_validation(client, url, body, field) -> None:
    answer = problem(client.post(url, json=body), 422, "validation")
    assert any(field in e["loc"] for e in answer["errors"]), answer


@needs_registry
@pytest.mark.parametrize(
    ("url", "body"),
    [
        (  # a PTP at a millionth of the joint limits: 3.6e5 s
            "/v1/trajectories/program",
            {"robot": "ur5", "start": {"positions": UR5_HOME}, "samples": 3,
             "segments": [{"type": "ptp", "goal": {"positions": UR5_TURN},
                           "velocity_scale": 1e-6, "acceleration_scale": 1e-6}]},
        ),
        (  # a Cartesian move at a micrometre per second
            "/v1/trajectories/cartesian",
            {"robot": "ur5", "start": {"positions": UR5_HOME}, "goal": {"positions": UR5_TURN},
             "method": "sampled", "max_linear_speed": 1e-6, "max_angular_speed": 1e-6,
             "samples": 3},
        ),
        (  # joint limits at their smallest: 1e6 s for one radian
            "/v1/trajectories/joint",
            {"profile": "trapezoidal", "start": {"positions": [0.0]}, "goal": {"positions": [1.0]},
             "limits": {"velocity": [1e-6], "acceleration": [1e-6]}, "samples": 3},
        ),
        (  # a spline timed by the smallest limits
            "/v1/trajectories/spline",
            {"waypoints": [[0.0], [1.0]], "boundary": "clamped", "limits": {"velocity": [1e-6], "acceleration": [1e-6]},
             "samples": 3},
        ),
    ],
)  # fmt: skip
@pytest.mark.parametrize("time_format", ["float", "ros"])
def test_a_plan_stretched_past_the_bound_is_infeasible(client, url, body, time_format) -> None:
    """Whatever field stretches the plan, the answer is 422 ``infeasible``, never a 200 with times
    past the bound (nor, in ROS format, negative seconds)."""
    answer = client.post(f"{url}?time_format={time_format}", json=body)
    problem(answer, 422, "infeasible")


def test_a_too_short_joint_duration_names_min_duration(client) -> None:
    """joint_rate_limit on a joint move states the shortest duration as ``min_duration`` (as the
    Cartesian answer does), at the field ``duration``; moving at exactly that duration is a 200."""
    body = {
        "profile": "quintic",
        "start": {"positions": [0.0]},
        "goal": {"positions": [1.0]},
        "limits": {"velocity": [1.0], "acceleration": [2.0]},
        "duration": 0.5,
    }
    answer = problem(client.post("/v1/trajectories/joint", json=body), 422, "joint_rate_limit")
    # Closed form of the rest-to-rest quintic: max(1.875 |dq| / v, sqrt(5.7735 |dq| / a)).
    assert answer["min_duration"] == pytest.approx(max(1.875, np.sqrt(10 / np.sqrt(3) / 2)))
    assert answer["errors"][0]["loc"] == ["body", "duration"]
    ok = client.post("/v1/trajectories/joint", json={**body, "duration": answer["min_duration"]})
    assert ok.status_code == 200, ok.text


def test_a_too_short_jerk_limited_duration_names_min_duration(client) -> None:
    body = {
        "profile": "jerk_limited",
        "start": {"positions": [0.0]},
        "goal": {"positions": [1.0]},
        "limits": {"velocity": [1.0], "acceleration": [2.0], "jerk": [10.0]},
        "duration": 0.5,
    }
    answer = problem(client.post("/v1/trajectories/joint", json=body), 422, "infeasible")
    assert "shortest_duration" not in answer
    fastest = client.post(
        "/v1/trajectories/joint", json={k: v for k, v in body.items() if k != "duration"}
    )
    assert answer["min_duration"] == pytest.approx(fastest.json()["diagnostics"]["duration"])
