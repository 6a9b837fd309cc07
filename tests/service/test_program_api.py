"""POST /v1/trajectories/program over HTTP: shape, segments, ROS rules, every error with `segment`.

Geometry is checked from the robot's own forward kinematics of the returned points; the LIN
segment ends are compared with the single-move endpoint (/v1/trajectories/cartesian).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from core.geometry.so3 import pose_to_matrix
from robots import registry
from service.app import create_app
from service.schemas.program import ProgramResponse
from service.settings import Settings
from tests.ros_rules import check_ros_trajectory

URL = "/v1/trajectories/program"
HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
UR5 = registry.get("ur5")
T0 = UR5.fk(np.array(HOME))
QUAT = [0.7071067811865476, 0.7071067811865475, 0.0, 0.0]  # T0's orientation (x, y, z, w)


def pose(dx: float, dy: float, dz: float) -> dict:
    return {"position": (T0[:3, 3] + [dx, dy, dz]).tolist(), "orientation": QUAT}


def point(dx: float, dy: float, dz: float) -> list[float]:
    return (T0[:3, 3] + [dx, dy, dz]).tolist()


def program(r: float = 0.02) -> dict:
    return {
        "robot": "ur5",
        "start": {"positions": HOME},
        "segments": [
            {"type": "lin", "goal": {"pose": pose(0.1, 0, 0)}, "blend_radius": r},
            {"type": "circ", "goal": {"pose": pose(0.1, 0.1, 0)}, "interim": point(0.13, 0.05, 0),
             "blend_radius": r},
            {"type": "lin", "goal": {"pose": pose(0.0, 0.1, 0)}, "blend_radius": r,
             "max_linear_speed": 0.1},
            {"type": "ptp", "goal": {"positions": HOME}, "velocity_scale": 0.5},
        ],
    }  # fmt: skip


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(Settings()))


def test_orientation_constant_matches_the_start_pose():
    assert np.allclose(pose_to_matrix(T0[:3, 3], np.array(QUAT)), T0, atol=1e-12)


def test_program_answer_shape_segments_and_ros_rules(client):
    r = client.post(URL, json=program())
    assert r.status_code == 200, r.text
    body = r.json()
    check_ros_trajectory(body, rest_to_rest=True)
    segs = body["segments"]
    assert [s["index"] for s in segs] == [0, 1, 2, 3]
    assert [s["type"] for s in segs] == ["lin", "circ", "lin", "ptp"]
    times = np.array([p["time_from_start"] for p in body["points"]])
    for a, b in itertools.pairwise(segs):
        assert a["blend_out"]["end_time"] == b["start_time"]
        assert a["end_time"] == a["blend_out"]["start_time"]
        for t in (a["end_time"], a["blend_out"]["end_time"]):
            assert np.min(np.abs(times - t)) == 0.0
    assert "blend_out" not in segs[-1]
    assert segs[-1]["end_time"] == body["diagnostics"]["duration"]
    assert body["points"][-1]["positions"] == HOME
    diag = body["diagnostics"]
    assert diag["method"] == "program" and diag["fraction"] == 1.0
    assert diag["max_position_deviation"] < 1e-6
    q = np.array([p["positions"] for p in body["points"]])
    qd = np.array([p["velocities"] for p in body["points"]])
    assert np.all(np.abs(qd) <= UR5.velocity_limits * (1 + 1e-9))
    # The last (PTP) segment uses half the velocity limits.
    last = times >= segs[-1]["start_time"]
    assert np.all(np.abs(qd[last]) <= 0.5 * UR5.velocity_limits * (1 + 1e-9))
    # The LIN at 0.1 m/s: the tool's speed between its points stays at or under it.
    sel = (times >= segs[2]["start_time"]) & (times <= segs[2]["end_time"])
    p = UR5.fk_many(q[sel])[:, :3, 3]
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(times[sel])
    assert speed.max() <= 0.1 * (1 + 1e-3)


def test_time_format_ros_applies_to_segment_times(client):
    r = client.post(URL + "?time_format=ros", json=program())
    assert r.status_code == 200
    ProgramResponse.model_validate(r.json())  # the documented response model holds
    ProgramResponse.model_validate(client.post(URL, json=program()).json())
    seg = r.json()["segments"][1]
    assert set(seg["start_time"]) == {"sec", "nanosec"}
    assert set(seg["blend_out"]["end_time"]) == {"sec", "nanosec"}


def test_lin_segment_ends_where_the_single_line_ends(client):
    single = {"robot": "ur5", "start": {"positions": HOME}, "goal": {"pose": pose(0.1, 0, 0)},
              "method": "sampled"}  # fmt: skip
    one = client.post("/v1/trajectories/cartesian", json=single).json()
    body = {"robot": "ur5", "start": {"positions": HOME},
            "segments": [{"type": "lin", "goal": {"pose": pose(0.1, 0, 0)}}]}  # fmt: skip
    mine = client.post(URL, json=body).json()
    a = np.array(one["points"][-1]["positions"])
    b = np.array(mine["points"][-1]["positions"])
    assert np.abs(a - b).max() < 1e-6


def _problem(r, code: str, status: int = 422) -> dict:
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    assert body["code"] == code
    return body


def _loc(body: dict) -> list:
    return body["errors"][0]["loc"]


@pytest.mark.parametrize(
    ("edit", "loc"),
    [
        (lambda b: b["segments"][0].update(blend_radius=0.06), ["body", "segments", 0, "blend_radius"]),
        (lambda b: b["segments"][3].update(blend_radius=0.01), ["body", "segments", 3, "blend_radius"]),
        (lambda b: b["segments"][1].update(interim=point(0.1, 0.05, 0)), ["body", "segments", 1, "interim"]),
        (lambda b: b["segments"][1].pop("interim") and b["segments"][1].update(center=point(0.1, 0.0505, 0)), ["body", "segments", 1, "center"]),
        (lambda b: b["segments"][0].update(velocity_scale=0.0), ["body", "segments", 0, "velocity_scale"]),
        (lambda b: b["segments"][0].update(acceleration_scale=1.5), ["body", "segments", 0, "acceleration_scale"]),
        (lambda b: b.update(segments=[]), ["body", "segments"]),
        (lambda b: b.update(segments=b["segments"][:1] * 101), ["body", "segments"]),
        (lambda b: b["segments"][0].update(type="spline"), ["body", "segments", 0]),
        (lambda b: b["segments"][3]["goal"].update(positions=[0.0] * 5), ["body", "segments", 3, "goal", "positions"]),
        (lambda b: b["segments"][0].update(blend_radius=float("nan")), ["body", "segments", 0]),
        (lambda b: b["segments"][2].update(method="taylor"), ["body", "segments", 2, "method"]),
    ],
)  # fmt: skip
def test_validation_errors_name_the_field(client, edit, loc):
    body = program()
    edit(body)
    r = client.post(URL, content=__import__("json").dumps(body).replace("NaN", "NaN"),
                    headers={"content-type": "application/json"})  # fmt: skip
    problem = _problem(r, "validation")
    got = problem["errors"][0]["loc"]
    # Inside a segment pydantic adds the segment's type tag after the index.
    got = got[:3] + got[4:] if len(got) > 4 and got[3] in {"lin", "circ", "ptp"} else got
    assert got[: len(loc)] == loc


PUMA = registry.get("puma560")
PUMA_START = [0.0, 0.5, -2.5, 0.0, 0.5, 0.0]
PUMA_GOAL = np.array([0.0, math.pi / 4, -math.pi, 0.0, 0.6, 0.0])


def _puma_pose_program(label: str | None) -> dict:
    T = PUMA.fk(PUMA_GOAL)
    quat = Rotation.from_matrix(T[:3, :3]).as_quat().tolist()
    goal: dict = {"pose": {"position": T[:3, 3].tolist(), "orientation": quat}}
    if label is not None:
        goal["configuration"] = label
    return {"robot": "puma560", "start": {"positions": PUMA_START},
            "segments": [{"type": "ptp", "goal": {"positions": [*PUMA_START[:4], 0.4, 0.0]}},
                         {"type": "ptp", "goal": goal}]}  # fmt: skip


def test_ptp_to_a_pose_takes_the_solution_with_the_label_nearest_the_joints(client):
    T = PUMA.fk(PUMA_GOAL)
    here = np.array([*PUMA_START[:4], 0.4, 0.0])  # the joints before the PTP
    sols = PUMA.ik_all(T, here)
    assert len(set(sols.configurations)) >= 3  # the pose has several labels: a real choice
    for label in set(sols.configurations):
        r = client.post(URL, json=_puma_pose_program(label))
        assert r.status_code == 200, r.text
        q = np.array(r.json()["points"][-1]["positions"])
        assert PUMA.configuration(q) == label
        assert np.abs(PUMA.fk(q) - T).max() < 1e-9
        mine = sols.positions[[c == label for c in sols.configurations]]
        best = mine[np.argmin(np.linalg.norm(mine - here, axis=1))]
        assert np.abs(q - best).max() < 1e-12
    # No label: the solution nearest the current joints of all.
    r = client.post(URL, json=_puma_pose_program(None))
    q = np.array(r.json()["points"][-1]["positions"])
    best = sols.positions[np.argmin(np.linalg.norm(sols.positions - here, axis=1))]
    assert np.abs(q - best).max() < 1e-12


def test_configuration_label_the_pose_lacks_is_unreachable_naming_the_labels(client):
    problem = _problem(
        client.post(URL, json=_puma_pose_program("right-down-noflip")), "unreachable"
    )
    assert problem["segment"] == 1 and problem["s"] == 1.0
    have = sorted(set(PUMA.ik_all(PUMA.fk(PUMA_GOAL), PUMA_GOAL).configurations))
    assert problem["configurations"] == have and "right-down-noflip" not in have
    for label in have:
        assert label in problem["detail"]
    # A label no robot of this family has, and a robot without labels: validation at the field.
    problem = _problem(client.post(URL, json=_puma_pose_program("sideways")), "validation")
    assert _loc(problem) == ["body", "segments", 1, "goal", "configuration"]
    body = {"robot": "panda", "start": {"positions": registry.get("panda").home.tolist()},
            "segments": [{"type": "ptp", "goal": {"pose": {"position": [0.3, 0.0, 0.5],
                          "orientation": [1.0, 0.0, 0.0, 0.0]}, "configuration": "up"}}]}  # fmt: skip
    problem = _problem(client.post(URL, json=body), "validation")
    assert _loc(problem) == ["body", "segments", 0, "goal", "configuration"]


def test_unreachable_segment_is_422_with_segment_and_s_or_partial(client):
    body = program()
    body["segments"][2]["goal"] = {"pose": pose(-1.0, 0.1, 0)}
    body["segments"][2]["blend_radius"] = 0.0
    problem = _problem(client.post(URL, json=body), "unreachable")
    assert problem["segment"] == 2 and isinstance(problem["segment"], int)
    assert 0.0 < problem["s"] < 1.0
    body["allow_partial"] = True
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    check_ros_trajectory(out, rest_to_rest=True)
    diag = out["diagnostics"]
    assert diag["failure"]["segment"] == 2 and diag["failure"]["code"] == "unreachable"
    assert 0.5 < diag["fraction"] < 0.75
    assert [s["index"] for s in out["segments"]] == [0, 1, 2]


def test_singular_segment_is_422_with_segment(client):
    q2, q3 = math.pi / 4, -math.pi
    body = {
        "robot": "puma560",
        "start": {"positions": [0.0, q2, q3, 0.0, 0.6, 0.0]},
        "segments": [
            {"type": "ptp", "goal": {"positions": [0.0, q2, q3, 0.0, 0.3, 0.0]}},
            {"type": "lin", "goal": {"positions": [0.0, q2, q3, 0.0, -0.3, 0.0]}},
        ],
    }
    r = client.post(URL, json=body)
    assert r.status_code == 422
    problem = r.json()
    assert problem["code"] in {"singularity", "branch_flip"}
    assert problem["segment"] == 1


def test_start_outside_limits_is_joint_limit_and_unknown_robot_404(client):
    body = program()
    body["start"]["positions"] = [10.0, *HOME[1:]]
    problem = _problem(client.post(URL, json=body), "joint_limit")
    assert _loc(problem) == ["body", "start", "positions", 0]
    body = program()
    body["robot"] = "nope"
    _problem(client.post(URL, json=body), "unknown_robot", 404)


def test_lin_past_a_joint_limit_is_joint_limit_with_segment(client):
    q0 = [*HOME[:5], 2 * math.pi - 0.1]
    T = UR5.fk(np.array(q0))
    c, s = math.cos(0.15), math.sin(0.15)  # the tool turned 0.3 rad about its z axis
    quat = (Rotation.from_matrix(T[:3, :3]) * Rotation.from_quat([0, 0, s, c])).as_quat()
    body = {
        "robot": "ur5",
        "start": {"positions": [*HOME[:5], 2 * math.pi - 0.15]},
        "segments": [
            {"type": "ptp", "goal": {"positions": q0}, "blend_radius": 0.0},
            {"type": "lin", "goal": {"pose": {"position": T[:3, 3].tolist(), "orientation": quat.tolist()}}},
        ],
    }  # fmt: skip
    problem = _problem(client.post(URL, json=body), "joint_limit")
    assert problem["segment"] == 1 and problem["joint"] == 5
    assert problem["s"] == pytest.approx(1 / 3, abs=1e-3)


def test_time_budget_is_422_with_segment():
    tight = TestClient(create_app(Settings(time_budget_s=1e-4)))
    problem = _problem(tight.post(URL, json=program()), "time_budget_exceeded")
    assert isinstance(problem.get("segment"), int)


def test_ptp_profiles_through_the_api(client):
    panda = registry.get("panda")
    q1 = (panda.home + 0.3).tolist()
    body = {"robot": "panda", "start": {"positions": panda.home.tolist()},
            "segments": [{"type": "ptp", "goal": {"positions": q1}, "profile": "jerk_limited"},
                         {"type": "ptp", "goal": {"positions": panda.home.tolist()},
                          "profile": "quintic", "velocity_scale": 0.5}],
            "sample_period": 1e-3}  # fmt: skip
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    check_ros_trajectory(out, rest_to_rest=True)
    t = np.array([p["time_from_start"] for p in out["points"]])
    a = np.array([p["accelerations"] for p in out["points"]])
    jerk = np.abs(np.diff(a, axis=0) / np.diff(t)[:, None])
    first = t[1:] <= out["segments"][0]["end_time"]
    assert np.all(jerk[first] <= panda.jerk_limits * (1 + 1e-6))
    peak = np.array(out["diagnostics"]["peak_jerk"])
    assert np.all(peak <= panda.jerk_limits * (1 + 1e-9)) and peak.max() > 1000.0
    body["robot"], body["start"]["positions"] = "ur5", HOME
    body["segments"] = [{"type": "ptp", "goal": {"positions": [*HOME[:5], 0.3]},
                         "profile": "jerk_limited"}]  # fmt: skip
    problem = _problem(client.post(URL, json=body), "validation")
    assert _loc(problem) == ["body", "segments", 0, "profile"]


def test_s_curve_lin_through_the_api(client):
    body = {"robot": "ur5", "start": {"positions": HOME}, "sample_period": 1e-3,
            "segments": [{"type": "lin", "goal": {"pose": pose(0.1, 0, 0)},
                          "speed_profile": "s_curve", "max_linear_jerk": 5.0}]}  # fmt: skip
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    pts = r.json()["points"]
    t = np.array([p["time_from_start"] for p in pts])
    keep = np.concatenate([[True], np.diff(t) > 5e-4])
    q = np.array([p["positions"] for p in pts])[keep]
    qd = np.array([p["velocities"] for p in pts])[keep]
    v = np.einsum("nij,nj->ni", np.array([UR5.jacobian(x)[:3] for x in q]), qd)
    a = np.diff(v, axis=0) / np.diff(t[keep])[:, None]
    tk = t[keep]
    jerk = np.linalg.norm(np.diff(a, axis=0), axis=1) / (0.5 * (tk[2:] - tk[:-2]))
    assert 4.5 < jerk.max() <= 5.0 * (1 + 1e-3)
    body["segments"][0]["max_linear_jerk"] = -1.0
    problem = _problem(client.post(URL, json=body), "validation")
    assert problem["errors"][0]["loc"][-1] == "max_linear_jerk"


def test_zero_length_segments_at_the_end_are_in_the_answer(client):
    """Every requested segment is in ``segments`` (trailing zero-length ones were left out): at the
    end of the answer, ``start_time == end_time``, skipped, with a warning."""
    body = {"robot": "ur5", "start": {"positions": HOME},
            "segments": [{"type": "lin", "goal": {"pose": pose(0.1, 0, 0)}},
                         {"type": "lin", "goal": {"pose": pose(0.1, 0, 0)}},
                         {"type": "ptp", "goal": {"pose": pose(0.1, 0, 0)}}]}  # fmt: skip
    r = client.post(URL, json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    end = out["diagnostics"]["duration"]
    assert [s["index"] for s in out["segments"]] == [0, 1, 2]
    for seg in out["segments"][1:]:
        assert seg["start_time"] == seg["end_time"] == end and seg["diagnostics"]["skipped"]
        assert any(f"segment {seg['index']} has zero length" in w
                   for w in out["diagnostics"]["warnings"])  # fmt: skip
    ProgramResponse.model_validate(out)


def _ball(center: np.ndarray, radius: float) -> dict:
    return {"name": "ball", "shape": {"type": "sphere", "radius": radius},
            "pose": {"position": center.tolist(), "orientation": [0.0, 0.0, 0.0, 1.0]}}  # fmt: skip


@pytest.mark.parametrize("second", ["lin", "ptp"])
def test_a_program_cut_by_a_collision_comes_to_rest_on_its_path(client, second):
    """``allow_partial`` with a ball across the second move (a LIN, or a trapezoidal PTP): was cut
    at the last clear returned point still moving, with a warning. Now the stretch holding the
    contact is re-timed to rest at that point along the same path: zero velocity and acceleration
    at the end, the limits held, the first stretch exactly as planned without the ball, the rest
    on the second move's path (line; joint segment), clear of the ball, ``fraction`` its share."""
    lift = {"type": "lin", "goal": {"pose": pose(0, 0, 0.1)}}
    free = {"robot": "ur5", "start": {"positions": HOME}, "sample_period": 0.004,
            "segments": [lift, {"type": "lin", "goal": {"pose": pose(0, 0.3, 0.1)}}]}  # fmt: skip
    if second == "ptp":
        free["segments"][1] = {"type": "ptp", "goal": {"pose": pose(0, 0.3, 0.1)},
                               "profile": "trapezoidal"}  # fmt: skip
    planned = client.post(URL, json=free).json()
    q = np.array([p["positions"] for p in planned["points"]])
    t = np.array([p["time_from_start"] for p in planned["points"]])
    stop = planned["segments"][0]["end_time"]
    q_stop, q_end = q[t == stop][0], q[-1]
    center = UR5.fk(q_stop + 0.6 * (q_end - q_stop))[:3, 3]  # the tool's place 60 % along
    body = {**free, "environment": {"obstacles": [_ball(center, 0.03)]}}
    assert _problem(client.post(URL, json=body), "collision")["segment"] == 1
    r = client.post(URL, json={**body, "allow_partial": True})
    assert r.status_code == 200, r.text
    out = r.json()
    got = check_ros_trajectory(out, rest_to_rest=True)
    diag = out["diagnostics"]
    assert diag["failure"]["code"] == "collision" and diag["failure"]["segment"] == 1
    assert diag["warnings"][0].startswith("planned ")
    assert not any("ends moving" in w for w in diag["warnings"])
    assert np.array_equal(got.velocities[-1], np.zeros(6))
    assert np.array_equal(got.accelerations[-1], np.zeros(6))
    assert np.all(np.array(diag["peak_velocity"]) <= UR5.velocity_limits * (1 + 1e-9))
    assert np.all(np.array(diag["peak_acceleration"]) <= UR5.acceleration_limits * (1 + 1e-9))
    n = int(np.flatnonzero(t == stop)[0]) + 1
    np.testing.assert_array_equal(got.positions[:n], q[:n])
    assert out["segments"][1]["end_time"] == got.times[-1]
    rest = got.positions[n - 1 :]
    if second == "lin":  # on the line within the tolerance, forward, short of the goal
        p = np.array([UR5.fk(x)[:3, 3] for x in rest]) - UR5.fk(q_stop)[:3, 3]
        assert np.abs(p[:, [0, 2]]).max() < 1e-3
        assert np.all(np.diff(p[:, 1]) >= -1e-9) and 0.0 < p[-1, 1] < 0.6 * 0.3
        share = p[-1, 1] / 0.3
    else:  # on the joint segment
        d = q_end - q_stop
        u = (rest - q_stop) @ d / (d @ d)
        assert np.abs(rest - q_stop - u[:, None] * d).max() < 1e-9
        assert np.all(np.diff(u) >= -1e-12) and 0.0 < u[-1] < 0.6
        share = u[-1]
    assert diag["fraction"] == pytest.approx((1 + share) / 2, abs=1e-3)
    assert diag["min_clearance"] >= 0.0
    assert diag["clearance_profile"]["time_from_start"][-1] == got.times[-1]
