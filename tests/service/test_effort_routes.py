"""Effort limits on every request that times its own motion (API.md "Dynamics: effort limits"):
programs, Cartesian requests and collision-free motions (joint, spline and retime have theirs in
their own tests).

The reference is pinocchio's RNEA, recomputed here from each answer's q, q', q'' at every returned
point and, between consecutive points, on the quintic through their q, q', q'' (intervals under
1e-4 s are left to their ends: they hold the time-optimal law's acceleration steps, and a quintic
over them is mostly rounding). Effort limits at 50 % of the maker's (the URDFs' ``effort``) on
the UR5 and the Panda; where those do not bind, limits just under the unconstrained answer's peak
(but above gravity's) check that the motion is slowed and still keeps them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest
from scipy.interpolate import BPoly

from robots import registry
from tests.service.conftest import pose_body
from tests.service.helpers import problem

PROGRAM = "/v1/trajectories/program"
CARTESIAN = "/v1/trajectories/cartesian"
FREE = "/v1/trajectories/collision_free"
GRAVITY = np.array([0.0, 0.0, -9.81])
NO_DYNAMICS = """<robot name="bare">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="10"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="1" effort="10"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="tip"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="1" effort="10"/></joint>
</robot>"""
BARE = {"urdf": NO_DYNAMICS, "tip_frame": "tip", "base_frame": "base"}


def torques(name: str, doc: dict[str, Any]) -> np.ndarray:
    """|tau| ``(M, dof)`` by pinocchio's RNEA at the returned points and between them."""
    pts = doc["points"]
    t = np.array([p["time_from_start"] for p in pts])
    data = np.stack([np.array([p[k] for p in pts]) for k in ("positions", "velocities",
                                                                "accelerations")], axis=1)  # fmt: skip
    poly = BPoly.from_derivatives(t, data)
    h = np.diff(t)
    f = np.arange(1, 4) / 4
    inner = (t[:-1, None] + h[:, None] * f)[h > 1e-4].ravel()
    q = np.vstack([data[:, 0], poly(inner)])
    qd = np.vstack([data[:, 1], poly(inner, 1)])
    qdd = np.vstack([data[:, 2], poly(inner, 2)])
    model = pin.Model(registry.get(name).model)
    model.gravity.linear = GRAVITY
    d = model.createData()
    return np.abs(np.array([pin.rnea(model, d, *x) for x in zip(q, qd, qdd, strict=True)]))


def corners(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    robot = registry.get(name)
    home = np.asarray(robot.home, dtype=float)
    lo, hi = np.asarray(robot.position_limits, dtype=float).T
    a = np.array([1.2, 0.8, -0.8, 0.9, 1.0, 1.0, 1.0])[: robot.dof]
    b = np.array([-1.0, -0.5, 0.6, -0.7, -1.0, -0.8, -1.0])[: robot.dof]
    return home, np.clip(home + a, lo + 0.1, hi - 0.1), np.clip(home + b, lo + 0.1, hi - 0.1)


def program(name: str, **extra: Any) -> dict[str, Any]:
    home, g1, g2 = corners(name)
    segs = [{"type": "ptp", "goal": {"positions": g1.tolist()}, "blend_radius": 0.05},
            {"type": "ptp", "goal": {"positions": g2.tolist()}}]  # fmt: skip
    return {"robot": name, "start": {"positions": home.tolist()}, "segments": segs, **extra}


def line(name: str, **extra: Any) -> dict[str, Any]:
    robot = registry.get(name)
    T = robot.fk(robot.home)
    T[:3, 3] += [0.15, 0.1, -0.1]
    return {"robot": name, "start": {"positions": list(robot.home)}, "goal": {"pose": pose_body(T)},
            "method": "sampled", "max_linear_speed": 1.0, "max_linear_acceleration": 20.0,
            "max_angular_speed": 3.0, "max_angular_acceleration": 30.0, **extra}  # fmt: skip


def binding(name: str, doc: dict[str, Any]) -> np.ndarray:
    """Limits under the unconstrained answer's peak torque on every joint where gravity leaves
    room (10 % over gravity's own peak), at least one of them binding."""
    tau = torques(name, doc)
    pts = np.array([p["positions"] for p in doc["points"]])
    model = pin.Model(registry.get(name).model)
    model.gravity.linear = GRAVITY
    d = model.createData()
    g = np.abs(np.array([pin.computeGeneralizedGravity(model, d, q) for q in pts])).max(axis=0)
    peak = tau.max(axis=0)
    limits = np.maximum(0.85 * peak, 1.1 * g)
    assert np.any(limits < peak)  # something binds
    return np.maximum(limits, 1e-3)


@pytest.mark.parametrize("name", ["ur5", "panda"])
@pytest.mark.parametrize("timing", ["time_optimal", "jerk_limited"])
def test_programs_keep_half_the_makers_effort_limits(client, name: str, timing: str) -> None:
    limits = 0.5 * registry.get(name).effort_limits
    r = client.post(PROGRAM, json=program(name, timing=timing, limits={"effort": limits.tolist()}))
    assert r.status_code == 200, r.text
    doc = r.json()
    tau = torques(name, doc)
    assert np.all(tau <= limits * (1 + 1e-6))
    peak = np.array(doc["diagnostics"]["peak_effort"])
    assert np.all(peak >= tau[: len(doc["points"])].max(axis=0) * (1 - 1e-9))


@pytest.mark.parametrize("name", ["ur5", "panda"])
@pytest.mark.parametrize("timing", ["time_optimal", "jerk_limited"])
def test_binding_effort_limits_slow_a_program_and_hold(client, name: str, timing: str) -> None:
    free = client.post(PROGRAM, json=program(name, timing=timing)).json()
    limits = binding(name, free)
    r = client.post(PROGRAM, json=program(name, timing=timing, limits={"effort": limits.tolist()}))
    assert r.status_code == 200, r.text
    doc = r.json()
    assert np.all(torques(name, doc) <= limits * (1 + 1e-6))
    assert doc["diagnostics"]["duration"] > free["diagnostics"]["duration"]


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_cartesian_lines_keep_effort_limits(client, name: str) -> None:
    half = 0.5 * registry.get(name).effort_limits
    r = client.post(CARTESIAN, json=line(name, limits={"effort": half.tolist()}))
    assert r.status_code == 200, r.text
    assert np.all(torques(name, r.json()) <= half * (1 + 1e-6))
    free = client.post(CARTESIAN, json=line(name)).json()
    limits = binding(name, free)
    r = client.post(CARTESIAN, json=line(name, limits={"effort": limits.tolist()}))
    assert r.status_code == 200, r.text
    doc = r.json()
    assert np.all(torques(name, doc) <= limits * (1 + 1e-6))
    assert doc["diagnostics"]["duration"] > free["diagnostics"]["duration"]
    assert any("effort" in w for w in doc["diagnostics"]["warnings"])
    with_duration = line(name, limits={"effort": limits.tolist()}, duration=2.0)
    for key in ("max_linear_speed", "max_linear_acceleration", "max_angular_speed",
                "max_angular_acceleration"):  # fmt: skip
        with_duration.pop(key)
    err = problem(client.post(CARTESIAN, json=with_duration), 422, "validation")
    assert err["errors"][0]["loc"][-2:] == ["limits", "effort"]


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_collision_free_motions_keep_effort_limits(client, name: str) -> None:
    home, g1, _ = corners(name)
    body = {"robot": name, "start": {"positions": home.tolist()},
            "goal": {"positions": g1.tolist()}}  # fmt: skip
    free = client.post(FREE, json=body).json()
    limits = binding(name, free)
    r = client.post(FREE, json={**body, "limits": {"effort": limits.tolist()}})
    assert r.status_code == 200, r.text
    doc = r.json()
    assert np.all(torques(name, doc) <= limits * (1 + 1e-6))
    assert doc["diagnostics"]["duration"] > free["diagnostics"]["duration"]
    assert len(doc["diagnostics"]["peak_effort"]) == registry.get(name).dof


def test_every_trajectory_answer_of_a_robot_with_dynamics_reports_peak_effort(client) -> None:
    home, g1, g2 = corners("ur5")
    answers = {
        "joint": client.post("/v1/trajectories/joint", json={
            "robot": "ur5", "profile": "trapezoidal", "start": {"positions": home.tolist()},
            "goal": {"positions": g1.tolist()}}),
        "spline": client.post("/v1/trajectories/spline", json={
            "robot": "ur5", "waypoints": [home.tolist(), g1.tolist(), g2.tolist()],
            "boundary": "clamped"}),
        "retime": client.post("/v1/trajectories/retime", json={
            "robot": "ur5", "waypoints": [home.tolist(), g1.tolist(), g2.tolist()]}),
        "cartesian": client.post(CARTESIAN, json=line("ur5")),
        "program": client.post(PROGRAM, json=program("ur5")),
        "collision_free": client.post(FREE, json={
            "robot": "ur5", "start": {"positions": home.tolist()},
            "goal": {"positions": g1.tolist()}}),
    }  # fmt: skip
    for route, r in answers.items():
        assert r.status_code == 200, (route, r.text)
        doc = r.json()
        peak = np.array(doc["diagnostics"]["peak_effort"])
        # at least the torque at the returned points, as pinocchio computes it
        assert np.all(peak >= torques("ur5", doc)[: len(doc["points"])].max(axis=0) * (1 - 1e-6))


def test_a_robot_without_dynamics_has_no_peak_effort_and_refuses_effort_limits(client) -> None:
    segs = [{"type": "ptp", "goal": {"positions": [0.5, 0.4, -0.3]}}]
    body = {"robot": BARE, "start": {"positions": [0.0, 0.2, 0.3]}, "segments": segs}
    r = client.post(PROGRAM, json=body)
    assert r.status_code == 200, r.text
    assert "peak_effort" not in r.json()["diagnostics"]
    err = problem(client.post(PROGRAM, json={**body, "limits": {"effort": [1, 1, 1]}}), 422,
                  "validation")  # fmt: skip
    assert err["errors"][0]["loc"][-2:] == ["limits", "effort"]
    free = {"robot": BARE, "start": {"positions": [0.0, 0.2, 0.3]},
            "goal": {"positions": [0.5, 0.4, -0.3]}, "limits": {"effort": [1, 1, 1]}}  # fmt: skip
    err = problem(client.post(FREE, json=free), 422, "validation")
    assert err["errors"][0]["loc"][-2:] == ["limits", "effort"]


@pytest.mark.parametrize("timing", ["time_optimal", "jerk_limited"])
def test_gravity_alone_over_a_limit_is_infeasible_naming_joint_segment_and_s(
    client, timing
) -> None:
    tiny = (0.05 * registry.get("ur5").effort_limits).tolist()
    err = problem(client.post(PROGRAM, json=program("ur5", timing=timing,
                                                   limits={"effort": tiny})), 422, "infeasible")  # fmt: skip
    assert err["joint"] == 1 and err["segment"] == 0 and err["s"] == pytest.approx(0.0, abs=1e-6)
    assert "gravity" in err["detail"] and "shoulder_lift_joint" in err["detail"]
    err = problem(client.post(CARTESIAN, json=line("ur5", limits={"effort": tiny})), 422,
                  "infeasible")  # fmt: skip
    assert err["joint"] == 1 and err["s"] == pytest.approx(0.0, abs=1e-6)
