"""Dense deviation measurement against an independent brute-force distance."""

from __future__ import annotations

import numpy as np

from core.cartesian.measure import dense_times, interpolate_linear, measure_deviation
from core.path.line import StraightLine
from core.trajectory import Trajectory
from tests.toy_kinematics import ToyPlanar2R


def test_dense_times_inserts_checks_and_keeps_samples():
    t = np.array([0.0, 0.5, 2.0])
    d = dense_times(t, 10)
    assert len(d) == 2 * 11 + 1
    assert np.all(np.diff(d) > 0)
    assert np.allclose(d[::11], t)


def test_joint_interpolation_deviation_matches_brute_force():
    arm = ToyPlanar2R()
    q0, q1 = np.array([0.3, 1.2]), np.array([1.1, 0.6])
    line = StraightLine(arm.fk(q0), arm.fk(q1), arm.task_space)
    times = np.array([0.0, 1.0])
    traj = Trajectory(times, np.vstack([q0, q1]), np.tile(q1 - q0, (2, 1)), np.zeros((2, 2)))
    rep = measure_deviation(arm, line, traj, checks=199)  # same grid as below
    # Brute force: distance of the joint-interpolated path to the segment.
    qs = interpolate_linear(times, traj.positions, np.linspace(0, 1, 201))
    p = arm.fk_many(qs)[:, :2, 3]
    a, b = line.T_start[:2, 3], line.T_goal[:2, 3]
    u = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    dist = np.linalg.norm(p - (a + u[:, None] * (b - a)), axis=1)
    assert abs(rep.max_position - dist.max()) < 1e-9
    assert rep.max_orientation == 0.0
    assert rep.segment_position.shape == (1,)


def test_on_line_samples_interpolated_linearly_stray_between_points():
    arm = ToyPlanar2R()
    q0 = np.array([0.3, 1.2])
    line = StraightLine(arm.fk(q0), arm.fk(np.array([1.1, 0.6])), arm.task_space)
    s = np.linspace(0, 1, 5)
    qs = [q0]
    for T in line.poses(s[1:]):
        qs.append(arm.ik(T, qs[-1]).positions)
    qs = np.array(qs)
    traj = Trajectory(s, qs, np.gradient(qs, s, axis=0), np.zeros_like(qs))
    rep = measure_deviation(arm, line, traj)
    assert np.all(rep.position[::11] < 1e-9)  # the samples are on the line
    assert rep.max_position > 1e-4  # between them, joint interpolation strays
    assert rep.segment_position.shape == (4,)
