"""Timing a collision-free motion's path (``core.motion.timing``): velocities and accelerations are
the exact derivatives of the positions (finite differences), every joint limit holds on a dense
grid, the motion stops where the path has a sharp corner, and ``StopAndGo`` stays on its straight
segments within the jerk limits."""

from __future__ import annotations

import numpy as np
import pytest

from core.joint.blended_path import BlendedPath
from core.motion.timing import StopAndGo, time_path
from core.timing.path_constraints import PathLimits

KNOTS = np.array(
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [1.2, 0.9, 0.1], [0.3, 1.1, -0.4], [0.2, 1.5, 0.0]]
)
V, A, J = np.array([1.0, 0.8, 2.0]), np.array([3.0, 2.0, 5.0]), np.array([30.0, 20.0, 50.0])


def dense(motion, n: int = 40001):
    t = np.linspace(0.0, motion.duration, n)
    return (t, *motion.sample(t))


@pytest.mark.parametrize("deviation", [0.0, 0.05, 0.3])
def test_blended_motion_keeps_the_limits(deviation: float) -> None:
    path = BlendedPath(KNOTS, np.full(len(KNOTS), deviation))
    motion = time_path(path, PathLimits(V, A))
    t, q, qd, qdd = dense(motion)
    assert np.all(np.abs(qd) <= V * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= A * (1 + 1e-9))
    np.testing.assert_allclose(q[[0, -1]], KNOTS[[0, -1]], atol=1e-9)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)
    # exact derivatives: central differences of q give qd, of qd give qdd (between grid kinks)
    dt = t[1] - t[0]
    np.testing.assert_allclose((q[2:] - q[:-2]) / (2 * dt), qd[1:-1], atol=5e-4)
    dqd = (qd[2:] - qd[:-2]) / (2 * dt)
    smooth = np.abs(qdd[2:] - qdd[:-2]).max(axis=1) < 1e-9
    np.testing.assert_allclose(dqd[smooth], qdd[1:-1][smooth], atol=1e-3)
    for s in path.stops():  # at rest at each sharp corner
        k = np.argmin(np.abs(np.linalg.norm(q - path(np.array([s]))[0], axis=1)))
        assert np.abs(qd[k]).max() < 1e-2


def test_stop_and_go_is_on_the_segments_within_jerk() -> None:
    motion = StopAndGo(KNOTS, V, A, J)
    t, q, qd, qdd = dense(motion)
    assert np.all(np.abs(qd) <= V * (1 + 1e-9)) and np.all(np.abs(qdd) <= A * (1 + 1e-9))
    jerk = np.abs(np.diff(qdd, axis=0)) / (t[1] - t[0])
    assert np.all(jerk <= J * (1 + 1e-6))
    # every sample on one of the segments
    seg = KNOTS[1:] - KNOTS[:-1]
    best = np.full(len(q), np.inf)
    for a, d in zip(KNOTS[:-1], seg, strict=True):
        u = np.clip(((q - a) @ d) / (d @ d), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(q - (a + u[:, None] * d), axis=1))
    assert best.max() < 1e-9
    starts = np.concatenate([[0.0], np.cumsum([law.duration for law in motion.laws])])
    at_knots = motion.sample(starts)  # at rest at each knot
    np.testing.assert_allclose(at_knots[0], KNOTS, atol=1e-12)
    np.testing.assert_allclose(at_knots[1], 0.0, atol=1e-12)
