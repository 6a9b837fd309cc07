"""API.md promises checked line by line (round 1): sampling (``sample_period`` spacing with the last
point at ``duration``), and resolved-rate plans of short lines from home within the acceleration
limits (they failed ``joint_rate_limit`` at 1.6e3x from a 1.6e-7 s last interval)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from core.trajectory import MIN_LAST_INTERVAL, sample_times
from robots import registry
from service.schemas.common import Pose

UR5 = registry.get("ur5")


@pytest.mark.parametrize("extra", [0.0, 1e-10, 1.6e-7, 9e-7, 1.1e-6, 0.0004, 0.0009999])
@pytest.mark.parametrize("period", [0.01, 0.001, 0.3])
def test_sample_period_grid(period: float, extra: float) -> None:
    """0, period, 2 period, ..., duration: every interval is the period except the last, which is
    in [MIN_LAST_INTERVAL, period + MIN_LAST_INTERVAL)."""
    duration = 37 * period + extra
    t = sample_times(duration, sample_period=period)
    assert t[0] == 0.0 and t[-1] == duration
    gaps = np.diff(t)
    np.testing.assert_allclose(gaps[:-1], period, rtol=0, atol=1e-12)
    assert MIN_LAST_INTERVAL <= gaps[-1] < period + MIN_LAST_INTERVAL
    assert len(t) == (38 if extra < MIN_LAST_INTERVAL else 39)


def tool_position(q) -> np.ndarray:
    """The tool point by pinocchio directly (not through the service's FK)."""
    model = UR5.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return data.oMf[model.getFrameId(UR5.tip_frame)].translation.copy()


@pytest.mark.parametrize("method", ["resolved_rate", "resolved_rate_dls"])
@pytest.mark.parametrize("offset", [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]])
def test_resolved_rate_follows_a_short_line_within_the_limits(
    client: TestClient, method: str, offset: list[float]
) -> None:
    T = UR5.fk(UR5.home)
    p0 = T[:3, 3].copy()
    T[:3, 3] += offset
    body = {
        "robot": "ur5",
        "method": method,
        "start": {"positions": UR5.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T).model_dump()},
    }
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    t = np.array([p["time_from_start"] for p in doc["points"]])
    q = np.array([p["positions"] for p in doc["points"]])
    a = np.array([p["accelerations"] for p in doc["points"]])
    assert np.diff(t).min() >= MIN_LAST_INTERVAL
    assert np.abs(a).max(axis=0) == pytest.approx(doc["diagnostics"]["peak_acceleration"], abs=1e-9)
    assert np.all(np.abs(a) <= UR5.acceleration_limits * (1 + 1e-6))
    # every returned point on the line (within the default 1 mm), the last at the goal
    axis = np.asarray(offset) / np.linalg.norm(offset)
    for qi in q:
        d = tool_position(qi) - p0
        assert np.linalg.norm(d - (d @ axis) * axis) <= 1e-3
    assert np.linalg.norm(tool_position(q[-1]) - T[:3, 3]) <= 1e-3


METHODS = [
    "sampled",
    "bounded_deviation",
    "bounded_deviation_nlp",
    "resolved_rate",
    "resolved_rate_dls",
]


@pytest.mark.parametrize("method", METHODS)
def test_allow_partial_answers_the_reachable_prefix_for_every_method(
    client: TestClient, method: str
) -> None:
    """A line 3 m out of the UR5's reach: 422 with a located ``code`` and ``s``, and with
    ``allow_partial`` a 200 prefix on the line within the limits (the rate methods were 422
    ``joint_rate_limit``: their ticks up to the singularity accelerate past the limits)."""
    T = UR5.fk(UR5.home)
    p0 = T[:3, 3].copy()
    T[:3, 3] += [3.0, 0.0, 0.0]
    body = {
        "robot": "ur5",
        "method": method,
        "start": {"positions": UR5.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T).model_dump()},
    }
    err = client.post("/v1/trajectories/cartesian", json=body).json()
    assert err["status"] == 422 and err["code"] in ("unreachable", "branch_flip", "singularity")
    assert 0.0 < err["s"] < 1.0
    answer = client.post("/v1/trajectories/cartesian", json={**body, "allow_partial": True})
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    diag = doc["diagnostics"]
    assert 0.0 < diag["fraction"] < 1.0
    assert diag["failure"]["code"] == err["code"] and diag["fraction"] <= diag["failure"]["s"]
    q = np.array([p["positions"] for p in doc["points"]])
    a = np.array([p["accelerations"] for p in doc["points"]])
    assert np.all(np.abs(a) <= UR5.acceleration_limits * (1 + 1e-6))
    for qi in q:
        d = tool_position(qi) - p0
        assert abs(d[1]) <= 1e-3 and abs(d[2]) <= 1e-3 and -1e-3 <= d[0] <= 3.0
    reached = tool_position(q[-1])[0] - p0[0]
    assert reached == pytest.approx(3.0 * diag["fraction"], abs=2e-3)


@pytest.mark.parametrize("boundary", ["clamped", "natural", "not-a-knot"])
def test_a_spline_timed_by_limits_never_exceeds_them(client: TestClient, boundary: str) -> None:
    """Knot times allocated for the limits: every peak <= its limit exactly (a natural spline
    peaked at 1.0000000000000002 rad/s for 1 rad/s), the binding one within 1e-9 of it."""
    body = {
        "waypoints": [[0, 0], [1, 0.5], [0.5, 1], [2, 0]],
        "boundary": boundary,
        "limits": {"velocity": [1.0, 1.0], "acceleration": [1.0, 1.0]},
    }
    answer = client.post("/v1/trajectories/spline", json=body)
    assert answer.status_code == 200, answer.text
    diag = answer.json()["diagnostics"]
    ratio = np.maximum(diag["peak_velocity"], np.sqrt(diag["peak_acceleration"]))
    assert np.all(np.asarray(diag["peak_velocity"]) <= 1.0)
    assert np.all(np.asarray(diag["peak_acceleration"]) <= 1.0)
    assert ratio.max() == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("method", ["sampled", "bounded_deviation", "bounded_deviation_nlp"])
def test_the_tool_keeps_max_linear_speed(client: TestClient, method: str) -> None:
    """max_linear_speed holds for the tool itself, not only along the line's parameter: the NLP's
    knot spline leaves the line within the tolerance and moved the tool at 0.051 m/s for a 0.05
    m/s limit. Tool speed by central differences of pinocchio FK around every returned point."""
    T = UR5.fk(UR5.home)
    T[:3, 3] += [0.2, 0.1, -0.1]
    body = {
        "robot": "ur5",
        "method": method,
        "start": {"positions": UR5.home.tolist()},
        "goal": {"pose": Pose.from_matrix(T).model_dump()},
        "max_linear_speed": 0.05,
    }
    answer = client.post("/v1/trajectories/cartesian", json=body)
    assert answer.status_code == 200, answer.text
    points = answer.json()["points"]
    h = 1e-6
    speeds = []
    for p in points:
        q, qd = np.asarray(p["positions"]), np.asarray(p["velocities"])
        speeds.append(
            np.linalg.norm(tool_position(q + h * qd) - tool_position(q - h * qd)) / (2 * h)
        )
    assert max(speeds) <= 0.05 * (1 + 1e-6)
    assert max(speeds) >= 0.05 * 0.99  # and it does go that fast
