"""Trajectory: exact peaks when the profile is known, sample-based peaks (and the sampled jerk)
when it is not; frozen."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core.joint.point_to_point import PointToPoint, plan_joint
from core.trajectory import Trajectory, sampled_peak_jerk


def test_exact_peaks_do_not_depend_on_the_samples() -> None:
    # Issue 19 item 5: a quintic 0 -> 1 rad in 1 s with 2 samples peaks at 1.875 rad/s and
    # 10/sqrt(3) rad/s^2 (the samples, both at rest, would say 0 and 0).
    traj = plan_joint(
        "quintic", PointToPoint.create([0.0], [1.0]), duration=1.0, samples=2
    ).trajectory
    np.testing.assert_array_equal(traj.velocities, 0.0)
    assert traj.peak_velocity[0] == pytest.approx(1.875, rel=1e-12)
    assert traj.peak_acceleration[0] == pytest.approx(5.773502691896258, rel=1e-12)
    assert traj.peak_jerk[0] == pytest.approx(60.0, rel=1e-12)


def test_without_a_profile_peaks_come_from_the_samples() -> None:
    t = np.linspace(0.0, 1.0, 11)
    acc = np.column_stack([np.sin(t), -2.0 * t])
    traj = Trajectory(t, np.zeros((11, 2)), np.column_stack([t, -t]), acc)
    np.testing.assert_array_equal(traj.peak_velocity, [1.0, 1.0])
    np.testing.assert_array_equal(traj.peak_acceleration, [np.sin(1.0), 2.0])
    # Largest slope between neighbours: cos(0) ~ the first interval's chord, and exactly 2.
    expected = [np.sin(0.1) / 0.1, 2.0]
    np.testing.assert_allclose(traj.peak_jerk, expected, rtol=1e-12)
    np.testing.assert_allclose(sampled_peak_jerk(t, acc), expected, rtol=1e-12)
    with pytest.raises(dataclasses.FrozenInstanceError):
        traj.times = t  # type: ignore[misc]
