"""API.md "Motion programs" checked line by line: blend spheres that overlap (any two, not only
neighbours), segment ends and blend window boundaries as returned points, LIN/CIRC keeping the
start's configuration label, CIRC about a centre on its circle, PTP to a pose with a label. FK by
pinocchio directly, not through the service."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from fastapi.testclient import TestClient

from robots import registry
from service.schemas.common import Pose
from tests.service.helpers import problem

UR5 = registry.get("ur5")
HOME = UR5.home.tolist()
URL = "/v1/trajectories/program"


def tool_position(q) -> np.ndarray:
    model = UR5.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return data.oMf[model.getFrameId(UR5.tip_frame)].translation.copy()


P0 = tool_position(UR5.home)


def at(offset) -> np.ndarray:
    """The tool position P0 + offset [m]."""
    return P0 + np.asarray(offset, dtype=float)


def pose(offset) -> dict[str, Any]:
    T = UR5.fk(UR5.home)
    T[:3, 3] += offset
    return Pose.from_matrix(T).model_dump()


def lin(offset, r: float = 0.0) -> dict[str, Any]:
    return {"type": "lin", "goal": {"pose": pose(offset)}, "blend_radius": r}


def program(segments: list[dict[str, Any]], **extra: Any) -> dict[str, Any]:
    return {"robot": "ur5", "start": {"positions": HOME}, "segments": segments, **extra}


def test_blend_spheres_at_both_ends_of_an_arc_that_overlap_are_422(client: TestClient) -> None:
    """A CIRC of three quarters of a 0.1 m circle: 0.47 m long, its ends 0.141 m apart. Radii of
    0.08 m at both ends are under half of every neighbour's length but overlap: 422 at the later
    segment's blend_radius; 0.07 m each (0.14 < 0.141) is fine."""
    center = at([0.0, 0.1, 0.0])
    circ = {
        "type": "circ",
        "goal": {"pose": pose([-0.1, 0.1, 0])},
        "interim": at([0.1, 0.1, 0.0]).tolist(),  # through the far side: the long arc
    }
    assert np.linalg.norm(at([0, 0, 0]) - center) == pytest.approx(0.1)
    segs = [lin([0.0, -0.2, 0], 0.08), {**circ, "blend_radius": 0.08}, lin([-0.1, 0.4, 0])]
    segs[1]["goal"]["pose"] = pose([-0.1, 0.1, 0])
    start = {"type": "lin", "goal": {"pose": pose([0, 0, 0])}}
    body = program([segs[0], start | {"blend_radius": 0.0}, *segs[1:]])
    body["segments"][1]["blend_radius"] = 0.08  # the sphere at the arc's start
    body["segments"][0]["blend_radius"] = 0.0
    err = problem(client.post(URL, json=body), 422, "validation")
    assert err["errors"][0]["loc"] == ["body", "segments", 2, "blend_radius"], err
    body["segments"][1]["blend_radius"] = body["segments"][2]["blend_radius"] = 0.07
    answer = client.post(URL, json=body)
    assert answer.status_code == 200, answer.text


def test_a_cycle_through_the_same_waypoints_blends_at_every_visit(client: TestClient) -> None:
    """A -> B -> A -> B with blends: the spheres at the two visits of A coincide, which is not an
    overlap of one segment's ends (pick-and-place cycles are the common case)."""
    a, b = [0.1, 0.0, 0.0], [0.1, 0.15, 0.0]
    segs = [lin(a, 0.03), lin(b, 0.03), lin(a, 0.03), lin(b, 0.03), lin(a)]
    answer = client.post(URL, json=program(segs))
    assert answer.status_code == 200, answer.text
    windows = [s["blend_out"] for s in answer.json()["segments"][:-1]]
    assert all(w is not None and w["end_time"] > w["start_time"] for w in windows)


@pytest.mark.parametrize("sampling", [{"samples": 7}, {"sample_period": 0.13}, {}])
def test_segment_ends_and_blend_boundaries_are_returned_points(
    client: TestClient, sampling: dict[str, Any]
) -> None:
    segs = [
        lin([0.1, 0, 0], 0.03),
        lin([0.1, 0.1, 0]),
        {"type": "ptp", "goal": {"positions": HOME}},
    ]
    answer = client.post(URL, json=program(segs, **sampling))
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    t = np.array([p["time_from_start"] for p in doc["points"]])
    q = np.array([p["positions"] for p in doc["points"]])
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    by_time = dict(zip(t.tolist(), q, strict=True))
    s0, s1, s2 = doc["segments"]
    for edge in (s0["blend_out"]["start_time"], s0["blend_out"]["end_time"], s1["end_time"]):
        assert edge in by_time
    assert s2["end_time"] == t[-1] == doc["diagnostics"]["duration"]
    # the unblended LIN end and the last PTP end are reached exactly
    assert np.linalg.norm(tool_position(by_time[s1["end_time"]]) - at([0.1, 0.1, 0])) < 1e-9
    np.testing.assert_allclose(q[-1], HOME, atol=1e-12)
    # the blend boundaries lie on the blend sphere about goal 0 (r = 0.03 m)
    for edge in (s0["blend_out"]["start_time"], s0["blend_out"]["end_time"]):
        d = np.linalg.norm(tool_position(by_time[edge]) - at([0.1, 0, 0]))
        assert d == pytest.approx(0.03, abs=1e-3)
    np.testing.assert_allclose(doc["points"][-1]["velocities"], 0.0, atol=1e-12)


def test_lin_and_circ_keep_the_configuration_of_their_start(client: TestClient) -> None:
    segs = [
        lin([0.3, 0.2, -0.1]),
        {
            "type": "circ",
            "goal": {"pose": pose([0.1, 0.3, 0])},
            "interim": at([0.25, 0.3, 0]).tolist(),
        },
    ]
    answer = client.post(URL, json=program(segs))
    assert answer.status_code == 200, answer.text
    q = np.array([p["positions"] for p in answer.json()["points"]])
    assert set(UR5.configurations(q)) == {UR5.configuration(UR5.home)}


def test_circ_about_a_center_stays_on_its_circle(client: TestClient) -> None:
    """Start P0, goal P0 + (0.1, 0.1, 0), centre P0 + (0, 0.1, 0): a quarter circle of radius 0.1 m
    in the plane z = P0.z (the shorter arc), within the default 1 mm tolerance at every point."""
    center = at([0.0, 0.1, 0.0])
    seg = {"type": "circ", "goal": {"pose": pose([0.1, 0.1, 0])}, "center": center.tolist()}
    answer = client.post(URL, json=program([seg]))
    assert answer.status_code == 200, answer.text
    points = np.array([tool_position(p["positions"]) for p in answer.json()["points"]])
    assert np.abs(np.linalg.norm(points - center, axis=1) - 0.1).max() <= 1e-3
    assert np.abs(points[:, 2] - P0[2]).max() <= 1e-3
    # the shorter arc: x never negative, y never above the centre's
    rel = points - P0
    assert rel[:, 0].min() >= -1e-3 and rel[:, 1].max() <= 0.1 + 1e-3
    assert np.linalg.norm(points[-1] - at([0.1, 0.1, 0])) < 1e-9


@pytest.mark.parametrize("label", ["right-up-noflip", "left-up-flip", "left-down-flip"])
def test_ptp_to_a_pose_with_a_configuration(client: TestClient, label: str) -> None:
    seg = {"type": "ptp", "goal": {"pose": pose([0.1, 0, 0]), "configuration": label}}
    answer = client.post(URL, json=program([seg]))
    assert answer.status_code == 200, answer.text
    q = answer.json()["points"][-1]["positions"]
    assert UR5.configuration(np.asarray(q)) == label
    assert np.linalg.norm(tool_position(q) - at([0.1, 0, 0])) < 1e-9


@pytest.mark.parametrize("second", ["ptp", "lin"])
def test_a_partial_program_counts_what_it_returns(client: TestClient, second: str) -> None:
    """A reachable LIN, then a PTP to a pose 3 m out of reach (nothing of it can be returned:
    fraction 1/2, was 1.0) or a LIN leaving the workspace (1/2 + half its s where it stops)."""
    far = {"type": second, "goal": {"pose": pose([-0.6 if second == "lin" else -3.0, 0, 0])}}
    body = program([lin([0.1, 0, 0]), far])
    err = problem(client.post(URL, json=body), 422, "unreachable")
    assert err["segment"] == 1
    answer = client.post(URL, json={**body, "allow_partial": True})
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    diag = doc["diagnostics"]
    assert diag["failure"]["code"] == "unreachable" and diag["failure"]["segment"] == 1
    end = tool_position(doc["points"][-1]["positions"])
    if second == "ptp":
        assert diag["fraction"] == 0.5
        assert np.linalg.norm(end - at([0.1, 0, 0])) < 1e-9
    else:  # on the second line, at s = 2 fraction - 1 of it
        s = 2 * diag["fraction"] - 1
        assert 0.0 < s < err["s"] + 1e-6
        assert np.linalg.norm(end - at([0.1 - 0.7 * s, 0, 0])) < 1e-3


def test_too_many_points_names_the_field_that_asked_for_them(client: TestClient) -> None:
    """100,000 regular samples plus the boundaries are over the limit: 422 ``too_large`` at
    ``samples`` (was at ``sample_period``, which the request did not send)."""
    segs = [lin([0.1, 0, 0], 0.03), lin([0.1, 0.1, 0])]
    err = problem(client.post(URL, json=program(segs, samples=100_000)), 422, "too_large")
    assert err["errors"][0]["loc"] == ["body", "samples"]
    err = problem(client.post(URL, json=program(segs, sample_period=1e-5)), 422, "too_large")
    assert err["errors"][0]["loc"] == ["body", "sample_period"]


def point_line_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    t = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)


@pytest.mark.parametrize("tolerance", [0.001, 0.005])
def test_bounded_deviation_lin_in_a_program(client: TestClient, tolerance: float) -> None:
    """API.md lets a LIN segment take ``method: bounded_deviation`` (was 422): a few IK knots, the
    tool within ``tolerance`` of the line everywhere (pinocchio FK of the returned points and of 10
    joint-linear points between each two), exactly on it at both ends."""
    goal = [0.3, 0.1, -0.1]
    seg = {
        "type": "lin",
        "goal": {"pose": pose(goal)},
        "method": "bounded_deviation",
        "tolerance": {"position": tolerance},
        "max_linear_speed": 0.1,
    }
    answer = client.post(URL, json=program([seg]))
    assert answer.status_code == 200, answer.text
    doc = answer.json()
    diag = doc["segments"][0]["diagnostics"]
    assert diag["method"] == "bounded_deviation" and 2 <= diag["knot_count"] <= 20
    q = np.array([p["positions"] for p in doc["points"]])
    u = np.linspace(0.0, 1.0, 11)[:-1]
    dense = (q[:-1, None, :] + u[None, :, None] * (q[1:] - q[:-1])[:, None, :]).reshape(
        -1, q.shape[1]
    )
    tool = np.array([tool_position(x) for x in [*dense, q[-1]]])
    worst = point_line_distance(tool, P0, at(goal)).max()
    assert worst <= tolerance
    assert np.linalg.norm(tool[-1] - at(goal)) < 1e-9
    h = 1e-6  # the tool's own speed (central differences of FK along the joint velocity)
    speed = [
        np.linalg.norm(tool_position(np.add(p["positions"], h * np.asarray(p["velocities"])))
                       - tool_position(np.add(p["positions"], -h * np.asarray(p["velocities"])))) / (2 * h)
        for p in doc["points"]
    ]  # fmt: skip
    assert max(speed) <= 0.1
    sampled = client.post(URL, json=program([{**seg, "method": "sampled"}])).json()
    assert sampled["segments"][0]["diagnostics"]["max_position_deviation"] < 1e-5
    if tolerance > 0.002:  # the knots use the band the sampled walk does not
        assert worst > 1e-5


def test_a_segment_goal_outside_the_joint_limits_names_its_segment(client: TestClient) -> None:
    """422 joint_limit with ``segment`` (API.md: a program failure adds it; was missing) and the
    joint's index in ``loc`` (the detail said "value 3" for joint index 3)."""
    panda = registry.get("panda")
    home = panda.home.copy()
    bad = home.copy()
    bad[3] = panda.position_limits[3, 1] + 0.2
    segs = [
        {"type": "ptp", "goal": {"positions": home.tolist()}},
        {"type": "ptp", "goal": {"positions": bad.tolist()}},
    ]
    body = {"robot": "panda", "start": {"positions": home.tolist()}, "segments": segs}
    err = problem(client.post(URL, json=body), 422, "joint_limit")
    assert err["segment"] == 1 and err["joint"] == 3
    assert err["errors"][0]["loc"] == ["body", "segments", 1, "goal", "positions", 3]
    assert "segments.1.goal.positions[3]" in err["detail"]
