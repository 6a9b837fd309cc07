"""The trapezoidal profile: synchronized joints, the triangle when the cruise speed is not reached,
exact peaks (zero jerk between the declared acceleration steps, and the warning)."""

from __future__ import annotations

import numpy as np
import pytest

from core.joint.motion import PointToPoint
from core.joint.profiles import PROFILES
from core.joint.profiles.trapezoidal import STEP_WARNING, TrapezoidalProfile


def test_trapezoid_is_synchronized_and_degrades_to_a_triangle() -> None:
    q0, q1 = np.zeros(3), np.array([4.0, 0.5, -1.0])
    amax = np.array([2.0, 2.0, 8.0])
    T = 2.0 * np.sqrt(4.0 / 2.0)  # joint 0's triangle time
    prof = TrapezoidalProfile(q0, q1, T, amax)
    assert prof.ramp[0] == pytest.approx(T / 2)  # triangle: no cruise
    assert np.all(prof.ramp[1:] < T / 2)  # the others cruise, slower
    t = np.linspace(0, T, 10_001)
    q = prof(t, 0)
    np.testing.assert_allclose(q[-1], q1, atol=1e-12)
    v = prof(t, 1)
    np.testing.assert_allclose(np.abs(v).max(axis=0), prof.cruise, rtol=1e-3)
    a = prof(t, 2)
    np.testing.assert_allclose(np.abs(a).max(axis=0), amax)
    # Cruise phase of joint 1: constant velocity.
    mid = (t > prof.ramp[1] + 1e-9) & (t < T - prof.ramp[1] - 1e-9)
    np.testing.assert_allclose(v[mid, 1], prof.cruise[1] * np.sign(q1[1]), rtol=1e-12)


def test_trapezoid_raises_the_acceleration_a_short_duration_needs() -> None:
    prof = TrapezoidalProfile(np.zeros(1), np.ones(1), 1.0, np.array([1.0]))
    # 4 |dq| / T^2 = 4 > 1: reported, so the planner's limit check catches it.
    assert prof.peaks()[1][0] == pytest.approx(4.0)


def test_jerk_is_zero_between_the_steps_and_the_steps_are_declared() -> None:
    prof = TrapezoidalProfile(np.zeros(2), np.array([1.0, -2.0]), 3.0, np.array([2.0, 2.0]))
    t = np.linspace(0.0, 3.0, 3001)
    acc = prof(t, 2)
    steps = np.abs(np.diff(acc, axis=0)) > 0
    assert 1 <= steps.sum(axis=0).min() and steps.sum(axis=0).max() <= 4  # only at the switches
    np.testing.assert_array_equal(prof.peaks().jerk, 0.0)
    assert STEP_WARNING in PROFILES["trapezoidal"].warnings(PointToPoint.create([0.0], [1.0]))
