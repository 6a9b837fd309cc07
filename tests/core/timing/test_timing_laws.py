"""Path-parameter profiles: closed forms, caps respected, inverses consistent."""

from __future__ import annotations

import numpy as np
import pytest

from core.timing.caps import joint_speed_cap
from core.timing.quintic import QuinticTiming
from core.timing.speed_limited import GridTiming, speed_limited


def test_quintic_rest_to_rest_and_peak():
    prof = QuinticTiming(2.0)
    t = np.linspace(0, 2.0, 2001)
    assert prof(np.array([0.0, 2.0])).tolist() == [0.0, 1.0]
    assert np.allclose(prof(np.array([0.0, 2.0]), 1), 0) and np.allclose(
        prof(np.array([0.0, 2.0]), 2), 0
    )
    assert prof(t, 1).max() == pytest.approx(1.875 / 2.0, rel=1e-6)
    # derivative consistency
    assert np.allclose(np.gradient(prof(t), t), prof(t, 1), atol=1e-5)
    assert np.allclose(prof(prof.time_at(np.array([0.25, 0.5]))), [0.25, 0.5], atol=1e-6)


@pytest.mark.parametrize(("length", "speed", "acc"), [(0.5, 0.25, 1.0), (0.05, 0.5, 1.0)])
def test_trapezoid_matches_closed_form(length, speed, acc):
    prof = speed_limited(length, 0.0, speed, None, max_linear_acceleration=acc)
    if speed**2 / acc < length:  # cruise reached
        expected = length / speed + speed / acc
    else:  # triangle
        expected = 2.0 * np.sqrt(length / acc)
    assert prof.duration == pytest.approx(expected, rel=1e-3)
    t = np.linspace(0, prof.duration, 5001)
    assert np.all(np.diff(prof(t)) >= -1e-15)
    assert prof(t, 1).max() * length <= speed * (1 + 1e-9)
    assert np.abs(prof(t, 2)).max() * length <= acc * (1 + 1e-9)
    assert prof(np.array([prof.duration]))[0] == pytest.approx(1.0, abs=1e-12)


def test_cap_slows_down_only_where_needed():
    s = np.linspace(0, 1, 2001)
    cap = np.where(np.abs(s - 0.5) < 0.1, 0.2, 5.0)
    prof = GridTiming(s, cap, 2.0)
    assert np.all(prof.sdot <= cap + 1e-12)
    assert prof.sdot[np.argmin(np.abs(s - 0.5))] == pytest.approx(0.2)
    assert prof.sdot[np.argmin(np.abs(s - 0.25))] > 0.2 * 2
    t = np.linspace(0, prof.duration, 4001)
    assert np.abs(prof(t, 2)).max() <= 2.0 + 1e-9
    assert np.allclose(prof(prof.time_at(s)), s, atol=1e-9)
    # integrating s' over time gives s
    assert np.allclose(np.trapezoid(prof(t, 1), t), 1.0, atol=1e-4)


def test_joint_speed_cap():
    dq = np.array([[1.0, 0.0], [2.0, -4.0], [0.0, 0.0]])
    cap = joint_speed_cap(dq, np.array([2.0, 2.0]))
    assert cap.tolist() == [2.0, 0.5, np.inf]
