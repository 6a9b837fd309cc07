"""The timing every Cartesian method shares: fixed durations, slow-downs, sampling, chain rule."""

from __future__ import annotations

import numpy as np
import pytest

from core.cartesian.timing import (
    MIN_SPEED_FRACTION,
    nominal_path_speed,
    sample_path,
    time_path,
    timed_trajectory,
)
from core.errors import JointRateLimit, Singularity
from core.timing.quintic import QuinticTiming
from core.timing.speed_limited import GridTiming
from tests.core import conftest
from tests.core.conftest import TOY_START
from tests.toy_kinematics import ToyPlanar2R


def toy_task(**kw):
    """The toy arm (velocity limits 2 rad/s, accelerations 10 rad/s^2) on a 0.5 m line along x."""
    goal_xy = ToyPlanar2R().fk(TOY_START)[:2, 3] + [0.5, 0.0]
    return conftest.toy_task(goal_xy=goal_xy, **kw)


S = np.linspace(0.0, 1.0, 401)


def test_grid_timing_per_interval_acceleration_bounds():
    cap = np.full(S.shape, 10.0)
    scalar = GridTiming(S, cap, 2.0)
    same = GridTiming(S, cap, np.full(len(S) - 1, 2.0))
    assert np.allclose(scalar.sdot, same.sdot) and scalar.duration == pytest.approx(same.duration)
    acc = np.where(S[:-1] < 0.5, 2.0, 0.5)
    prof = GridTiming(S, cap, acc)
    assert np.all(np.abs(prof.sddot) <= acc * (1 + 1e-9))
    assert prof.duration > scalar.duration
    assert np.allclose(prof(prof.time_at(S)), S, atol=1e-9)


def test_fixed_duration_refuses_joint_speeds_over_the_limit_with_min_duration():
    dq = np.tile([1.0, -0.5], (len(S), 1))  # a joint moves 1 rad along the line
    # The quintic's peak s' is 1.875 / T, so the shortest duration is 1.875 * 1 / 2 s.
    timing = time_path(toy_task(duration=0.9376), toy_task().line(), S, dq)
    assert timing.duration == 0.9376 and timing.end == 1.0
    with pytest.raises(JointRateLimit) as err:
        time_path(toy_task(duration=0.9), toy_task().line(), S, dq)
    assert err.value.extra["min_duration"] == pytest.approx(0.9375, rel=1e-4)
    assert 0.3 < err.value.s < 0.5 and err.value.joint == 0


def test_speed_limits_slow_down_only_where_a_joint_needs_it():
    task = toy_task(max_linear_speed=0.25)  # 0.5 unit of s per second
    line = task.line()
    assert nominal_path_speed(task, line) == pytest.approx(0.5)
    bump = np.exp(-(((S - 0.5) / 0.05) ** 2))
    dq = np.column_stack([0.5 + 7.5 * bump, np.full(len(S), 0.1)])  # 8 rad per unit s at s = 0.5
    timing = time_path(task, line, S, dq)
    sdot = timing.profile(timing.profile.time_at(S), 1)
    assert np.all(np.abs(dq[:, 0]) * sdot <= 2.0 * (1 + 1e-9))
    assert sdot[200] == pytest.approx(0.25, rel=1e-3)  # 2 rad/s over 8 rad per unit s
    assert sdot[100] == pytest.approx(0.5, rel=1e-5)  # the requested speed away from it
    assert timing.slowdown == pytest.approx(0.5, rel=1e-3)
    (warning,) = timing.warnings
    assert "joint velocity limits slow the tool" in warning and "50.0%" in warning
    dq[200, 0] = 2.0 / (0.25 * MIN_SPEED_FRACTION)
    with pytest.raises(Singularity):
        time_path(task, line, S, dq)


def test_samples_and_chain_rule():
    task = toy_task(duration=2.0, samples=9)
    dq = np.tile([0.3, 0.2], (len(S), 1))
    timing = time_path(task, task.line(), S, dq)
    times, s = sample_path(task, timing)
    assert np.allclose(s, np.linspace(0, 1, 9)) and times[-1] == 2.0
    assert np.allclose(QuinticTiming(2.0)(times), s, atol=1e-12)
    q = s[:, None] * [0.3, 0.2]
    traj = timed_trajectory(times, timing, q, np.tile([0.3, 0.2], (9, 1)), np.zeros((9, 2)))
    assert np.all(traj.velocities[[0, -1]] == 0.0)
    assert np.allclose(traj.velocities[4], [0.3 * 1.875 / 2, 0.2 * 1.875 / 2])
    period = toy_task(duration=2.0, sample_period=0.3)
    times, s = sample_path(period, time_path(period, period.line(), S, dq))
    assert np.allclose(np.diff(times)[:-1], 0.3) and times[-1] == 2.0 and s[-1] == 1.0
