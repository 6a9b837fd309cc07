"""The jerk-limited timing of a joint path against independent references.

- Ruckig (time-optimal jerk-limited, one joint at a time): on a straight joint path no motion within
  the same limits is shorter than Ruckig's, so ours is at least that long (and not far off).
- The limits, checked on a dense resampling in time: the jerk by finite differences of the returned
  accelerations (and the exact q'''), velocity and acceleration; acceleration continuous, zero at
  both ends.
- Finite differences of the returned positions and velocities (exact derivatives), and q(t) on the
  path.
- The duration at least the time-optimal one (toppra-checked in test_topp.py) of the same path.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.joint.spline_path import SplinePath
from core.timing.path_constraints import Effort, PathLimits
from core.timing.path_jerk import JerkLimited, jerk_limited
from core.timing.topp import time_optimal
from tests.core.timing.helpers import Pendulums, walk

TOLERANCE = 1e-9
ruckig = pytest.importorskip("ruckig")


def dense(result: JerkLimited, points: int = 200_001) -> tuple[np.ndarray, ...]:
    t = np.linspace(0.0, result.duration, points)
    return (t, *result.sample(t), result.sample_jerk(t))


def check_limits(result: JerkLimited, v: np.ndarray, a: np.ndarray, j: np.ndarray) -> None:
    t, _, qd, qdd, qddd = dense(result)
    assert (np.abs(qd) / v).max() <= 1.0 + TOLERANCE
    assert (np.abs(qdd) / a).max() <= 1.0 + TOLERANCE
    assert (np.abs(qddd) / j).max() <= 1.0 + TOLERANCE
    # the returned accelerations' own slopes (an independent estimate of the jerk): within it
    slopes = np.abs(np.diff(qdd, axis=0)) / np.diff(t)[:, None]
    assert (slopes / j).max() <= 1.0 + 1e-6
    # acceleration continuous and zero at rest at both ends
    np.testing.assert_allclose(qdd[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)


@pytest.mark.parametrize(
    ("goal", "v", "a", "j"),
    [
        ([1.0, 0.5], [1.0, 2.0], [2.0, 5.0], [10.0, 50.0]),
        ([3.0, -1.0, 0.2], [1.0, 1.0, 1.0], [3.0, 3.0, 3.0], [20.0, 20.0, 20.0]),
        ([0.3, 0.1], [2.0, 2.0], [10.0, 10.0], [100.0, 100.0]),
    ],
)
def test_a_straight_path_against_ruckig(goal: list[float], v: list[float], a: list[float],
                                        j: list[float]) -> None:  # fmt: skip
    q1 = np.array(goal)
    q0 = np.zeros_like(q1)
    v_, a_, j_ = (np.array(x) for x in (v, a, j))
    result = jerk_limited(SplinePath(np.stack([q0, q1])), PathLimits(v_, a_), j_)
    inp = ruckig.InputParameter(len(q1))
    inp.current_position, inp.target_position = q0.tolist(), q1.tolist()
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = v, a, j
    reference = ruckig.Trajectory(len(q1))
    ruckig.Ruckig(len(q1)).calculate(inp, reference)
    print(f"ours {result.duration:.4f} s, ruckig {reference.duration:.4f} s")
    assert result.duration >= reference.duration * (1.0 - 1e-9)
    assert result.duration <= 1.25 * reference.duration
    check_limits(result, v_, a_, j_)


@pytest.mark.parametrize("seed", [0, 3])
def test_a_curved_path_keeps_every_limit(seed: int) -> None:
    path = SplinePath(walk(seed, 12, dof=4))
    v, a, j = np.full(4, 2.0), np.full(4, 8.0), np.full(4, 60.0)
    limits = PathLimits(v, a)
    result = jerk_limited(path, limits, j)
    check_limits(result, v, a, j)
    optimal = time_optimal(path, limits)
    assert result.time_optimal_duration == pytest.approx(optimal.duration, rel=1e-12)
    assert result.duration >= optimal.duration
    print(f"seed {seed}: {result.duration / optimal.duration:.3f}x the time-optimal duration")
    assert result.duration <= 2.0 * optimal.duration
    # exact derivatives: central differences of the returned q and q'
    t = np.linspace(0.01, result.duration - 0.01, 997)
    h = 1e-6
    q_p, qd_p, _ = result.sample(t + h)
    q_m, qd_m, _ = result.sample(t - h)
    _, qd, qdd = result.sample(t)
    np.testing.assert_allclose((q_p - q_m) / (2 * h), qd, atol=1e-6)
    np.testing.assert_allclose((qd_p - qd_m) / (2 * h), qdd, atol=1e-5)
    # every point on the path
    np.testing.assert_allclose(result.sample(t)[0], path(result(t)), atol=0.0)


def test_effort_limits_hold_with_jerk_limits() -> None:
    path = SplinePath(walk(6, 8, dof=3, step=0.6))
    g = np.array([0.0, 0.0, -9.81])
    dyn = Pendulums()
    effort = np.array([8.0, 4.0, 2.0])
    v, a, j = np.full(3, 3.0), np.full(3, 20.0), np.full(3, 150.0)
    result = jerk_limited(path, PathLimits(v, a, effort=Effort(dyn, effort, g)), j)
    _, q, qd, qdd, qddd = dense(result)
    tau = dyn.inverse_dynamics(q, qd, qdd, g)
    assert (np.abs(tau) / effort).max() <= 1.0 + TOLERANCE
    assert (np.abs(qddd) / j).max() <= 1.0 + TOLERANCE
