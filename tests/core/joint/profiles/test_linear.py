"""The linear profile: constant velocity between declared steps, rest at both returned ends, and
its warning; peaks from the cruise speed."""

from __future__ import annotations

import numpy as np

from core.joint.motion import PointToPoint
from core.joint.profiles import PROFILES
from core.joint.profiles.linear import STEP_WARNING, LinearProfile


def test_linear_declares_its_velocity_steps() -> None:
    q0, q1, T = np.array([0.0, 1.0]), np.array([2.0, -1.0]), 4.0
    prof = LinearProfile(q0, q1, T)
    t = np.linspace(0, T, 9)
    v = prof(t, 1)
    np.testing.assert_array_equal(v[0], 0.0)
    np.testing.assert_array_equal(v[-1], 0.0)
    np.testing.assert_allclose(v[1:-1], np.tile((q1 - q0) / T, (7, 1)))
    np.testing.assert_array_equal(prof(t, 2), 0.0)
    np.testing.assert_allclose(prof(t, 0), q0 + np.outer(t / T, q1 - q0))


def test_peaks_and_the_warning() -> None:
    prof = LinearProfile(np.array([0.0, 1.0]), np.array([2.0, -1.0]), 4.0)
    np.testing.assert_array_equal(prof.peaks().velocity, [0.5, 0.5])
    np.testing.assert_array_equal(prof.peaks().acceleration, 0.0)
    np.testing.assert_array_equal(prof.peaks().jerk, 0.0)
    warnings = PROFILES["linear"].warnings(PointToPoint.create([0.0], [1.0]))
    assert warnings == (STEP_WARNING,)
