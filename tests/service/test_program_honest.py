"""Programs honest between their points (issue 25 items 1-4, issue 26 items 1, 7, 8), over HTTP.

Every check is independent of the planner: the returned points alone (integrals of the returned
accelerations and velocities, finite differences), pinocchio's forward kinematics of the returned
positions against the closed-form lines, and the robot's published limits.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from robots import registry
from service.app import create_app
from service.schemas.common import Pose
from tests.service.helpers import problem

URL = "/v1/trajectories/program"
UR5 = registry.get("ur5")
PANDA = registry.get("panda")
HOME = UR5.home.tolist()


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app())


def tool(robot: Any, qs: np.ndarray) -> np.ndarray:
    """Tool positions ``(N, 3)`` by pinocchio directly (not through the service's model)."""
    model, data = robot.model, robot.model.createData()
    frame = model.getFrameId(robot.tip_frame)
    out = []
    for q in qs:
        pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
        out.append(data.oMf[frame].translation.copy())
    return np.array(out)


def pose(robot: Any, q: Any, offset: Any) -> dict:
    T = robot.fk(np.asarray(q, dtype=float))
    T[:3, 3] += offset
    return Pose.from_matrix(T).model_dump()


def lin(offset: Any, r: float = 0.0, robot: Any = UR5, q: Any = HOME) -> dict:
    return {"type": "lin", "goal": {"pose": pose(robot, q, offset)}, "blend_radius": r}


def rectangle(r: float) -> list[dict]:
    return [lin([0.1, 0, 0], r), lin([0.1, 0.1, 0], r), lin([0, 0.1, 0], r), lin([0, 0, 0])]


def circ(**kw: Any) -> dict:
    return {"type": "circ", "goal": {"pose": pose(UR5, HOME, [0.1, 0.1, 0])}, **kw}


P0 = UR5.fk(UR5.home)[:3, 3]
PROGRAMS = {
    "rectangle, 3 cm blends": rectangle(0.03),
    "rectangle, stops": rectangle(0.0),
    "circ via interim": [circ(interim=(P0 + np.array([0.08, 0.02, 0.0])).tolist())],
    "circ about a centre": [circ(center=(P0 + np.array([0.1, 0.0, 0.0])).tolist())],
    "ptp-lin-ptp": [
        {"type": "ptp", "goal": {"positions": (UR5.home + 0.1).tolist()}, "blend_radius": 0.02},
        lin([0.05, 0.05, -0.05], 0.02, UR5, UR5.home + 0.1),
        {"type": "ptp", "goal": {"positions": HOME}},
    ],
}


def body(segments: list[dict], robot: str = "ur5", start: Any = HOME, **extra: Any) -> dict:
    return {"robot": robot, "start": {"positions": list(start)}, "segments": segments, **extra}


def pick_and_place() -> dict:
    """PTP above the pick, LIN down and up, PTP above the place, LIN down (blended PTPs)."""
    q0 = PANDA.home
    pick = PANDA.ik(PANDA.fk(q0) @ np.diag([1.0, 1.0, 1.0, 1.0]), q0).positions
    place = (q0 + np.array([0.4, 0, 0, 0, 0, 0, 0])).tolist()
    segs = [
        {"type": "ptp", "goal": {"positions": pick.tolist()}},
        lin([0.0, 0.0, -0.08], 0.02, PANDA, pick),
        lin([0.0, 0.0, 0.0], 0.02, PANDA, pick),
        {"type": "ptp", "goal": {"positions": place}, "blend_radius": 0.02},
        lin([0.0, 0.0, -0.08], 0.0, PANDA, place),
    ]
    return body(segs, "panda", (q0 - 0.2).tolist())


def points(doc: dict) -> tuple[np.ndarray, ...]:
    p = doc["points"]
    return tuple(
        np.array([x[key] for x in p], dtype=float)
        for key in ("time_from_start", "positions", "velocities", "accelerations")
    )


CASES = {
    **{name: body(segs) for name, segs in PROGRAMS.items()},
    "panda pick and place": pick_and_place(),
}


@pytest.fixture(scope="module")
def answers(client) -> dict[str, dict]:
    out = {}
    for name, request in CASES.items():
        r = client.post(URL, json=request)
        assert r.status_code == 200, (name, r.text)
        out[name] = r.json()
    return out


@pytest.mark.parametrize("name", list(CASES))
def test_returned_rates_are_the_exact_derivatives_of_the_returned_motion(answers, name):
    """25.1: integrating the returned accelerations between consecutive points gives the returned
    velocities to 1e-6 rad/s (was off by 1.5e-4 to 4.4e-3 on these programs); 25.2: the motion
    between two points is the one polynomial the points describe (acceleration linear: so it is
    continuous at every point, blend exits included), which the positions confirm to 1e-9 rad."""
    t, q, v, a = points(answers[name])
    h = np.diff(t)[:, None]
    assert np.abs(np.diff(v, axis=0) - 0.5 * (a[1:] + a[:-1]) * h).max() <= 1e-6
    cubic = q[:-1] + v[:-1] * h + (2.0 * a[:-1] + a[1:]) * h**2 / 6.0
    assert np.abs(q[1:] - cubic).max() <= 1e-9


@pytest.mark.parametrize("name", list(CASES))
def test_peak_jerk_is_never_below_the_returned_motions_jerk(answers, name):
    """25.3: the jerk of the returned motion (finite differences of the returned accelerations:
    exact for it) never exceeds ``peak_jerk`` (was 292.7 against 239.9 after a PTP-LIN blend)."""
    t, _, _, a = points(answers[name])
    jerk = np.abs(np.diff(a, axis=0) / np.diff(t)[:, None]).max(axis=0)
    peak = np.array(answers[name]["diagnostics"]["peak_jerk"])
    assert np.all(jerk <= peak * (1 + 1e-9) + 1e-9)


def test_a_program_that_does_not_move_is_200_at_rest_with_a_warning(client):
    """25.4: was 422 validation; as Pilz answers a LIN to its own start."""
    here = lin([0.0, 0.0, 0.0])
    r = client.post(URL, json=body([here, {"type": "ptp", "goal": {"positions": HOME}}]))
    assert r.status_code == 200, r.text
    doc = r.json()
    _, q, v, a = points(doc)
    assert len(q) >= 2 and np.all(q == np.array(HOME)) and not v.any() and not a.any()
    assert any("zero length" in w for w in doc["diagnostics"]["warnings"])
    assert all(s["diagnostics"]["skipped"] for s in doc["segments"])


def test_a_vanishing_acceleration_scale_is_a_4xx_naming_the_field(client):
    """26.1: a blended LIN with acceleration_scale 1e-30 was a 500."""
    segs = [lin([0.1, 0, 0], 0.02) | {"acceleration_scale": 1e-30}, lin([0.1, 0.1, 0])]
    err = problem(client.post(URL, json=body(segs)), 422, "infeasible")
    assert err["errors"][0]["loc"] == ["body", "segments", 0, "acceleration_scale"]


@pytest.mark.parametrize("radius", [1e-9, 1e-6, 1e-4])
def test_outside_a_tiny_blend_sphere_each_lin_stays_on_its_line(client, radius):
    """26.7: blend_radius 1e-9 left the LIN 2.41 mm off its line (tolerance 1 mm), with only a
    warning. Every returned point outside the sphere is within 1e-6 m of its line (pinocchio FK
    against the closed-form segment)."""
    corner = P0 + np.array([0.1, 0.0, 0.0])
    r = client.post(URL, json=body([lin([0.1, 0, 0], radius), lin([0.1, 0.1, 0])]))
    assert r.status_code == 200, r.text
    p = tool(UR5, points(r.json())[1])
    first = np.hypot(p[:, 1] - P0[1], p[:, 2] - P0[2])  # off the line along x
    second = np.hypot(p[:, 0] - corner[0], p[:, 2] - corner[2])  # off the line along y
    outside = np.linalg.norm(p - corner, axis=1) > radius * (1 + 1e-6)
    assert np.minimum(first, second)[outside].max() <= 1e-6
    assert not any("strays" in w for w in r.json()["diagnostics"]["warnings"])


def test_a_partial_program_keeps_its_scaled_limits(client):
    """26.8: an allow_partial prefix reached 0.456831 rad/s against a scaled limit of 0.456670.
    Two fast LINs at velocity_scale 0.3, the second out of reach: the prefix's returned
    velocities, and its exact peaks, within 0.3 of each joint's limit."""
    scale = 0.3
    fast = {"velocity_scale": scale, "max_linear_speed": 2.0}
    near, far = lin([0.0, 0.3, 0.0]) | fast, lin([0.0, 3.0, 0.0]) | fast
    r = client.post(URL, json=body([near, far], allow_partial=True))
    assert r.status_code == 200, r.text
    doc = r.json()
    assert doc["diagnostics"]["fraction"] < 1.0
    limit = scale * np.asarray(UR5.velocity_limits)
    _, _, v, _ = points(doc)
    assert np.all(np.abs(v) <= limit * (1 + 1e-9))
    assert np.all(np.array(doc["diagnostics"]["peak_velocity"]) <= limit * (1 + 1e-9))
