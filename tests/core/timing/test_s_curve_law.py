"""The ``s_curve`` timing law of ``TIMING_LAWS`` and its use by Cartesian plans (``speed_profile``).

Path limits are checked on the profile's own derivatives and on finite differences of s(t); the
Cartesian plans are checked from the forward kinematics of their returned joints (s(t) recovered by
projecting the tool point on the line, then differenced), never from diagnostics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.cartesian.plan import plan
from core.cartesian.task import CartesianTask
from core.errors import Infeasible, InputError
from core.timing import TIMING_LAWS, TimingSpec
from core.timing.speed_limited import DEFAULT_LINEAR_ACCELERATION
from robots import registry

LENGTH, ANGLE = 0.4, 0.5
V, W, J = 0.25, 1.0, 4.0


def derivatives(profile, n: int = 20001):
    t = np.linspace(0.0, profile.duration, n)
    return t, [np.asarray(profile(t, k)) for k in range(3)]


def test_s_curve_law_keeps_every_path_limit() -> None:
    spec = TimingSpec(LENGTH, ANGLE, max_linear_speed=V, max_angular_speed=W, max_linear_jerk=J)
    profile = TIMING_LAWS["s_curve"](spec)
    t, (s, sd, sdd) = derivatives(profile)
    assert s[0] == 0.0 and s[-1] == 1.0 and sd[0] == sd[-1] == 0.0 and sdd[0] == sdd[-1] == 0.0
    assert np.all(np.diff(s) >= 0.0)
    assert LENGTH * sd.max() <= V * (1 + 1e-9) and ANGLE * sd.max() <= W * (1 + 1e-9)
    assert LENGTH * np.abs(sdd).max() <= DEFAULT_LINEAR_ACCELERATION * (1 + 1e-9)
    # s'' continuous: its steps are within the jerk bound times the time step.
    dt = t[1] - t[0]
    jerk = np.abs(np.diff(sdd)) / dt
    assert LENGTH * jerk.max() <= J * (1 + 1e-6)
    # And the jerk limit is used (the profile is not merely slow): the bound is reached.
    assert LENGTH * jerk.max() >= 0.99 * J
    np.testing.assert_allclose(profile.time_at(s[::500]), t[::500], atol=1e-9)


def test_s_curve_law_scales_to_a_partial_end() -> None:
    """A partial plan's s runs from 0 to ``end``: the tool limits still hold on the real s."""
    end = 0.6
    spec = TimingSpec(LENGTH, ANGLE, max_linear_speed=V, max_linear_jerk=J, end=end)
    profile = TIMING_LAWS["s_curve"](spec)
    t, (s, sd, sdd) = derivatives(profile)
    assert s[-1] == pytest.approx(end, abs=1e-15) and s[0] == 0.0
    assert LENGTH * sd.max() <= V * (1 + 1e-9)
    assert LENGTH * np.abs(np.diff(sdd)).max() / (t[1] - t[0]) <= J * (1 + 1e-6)
    np.testing.assert_allclose(profile(profile.time_at(s[::997])), s[::997], atol=1e-9)


def test_s_curve_law_with_a_duration() -> None:
    profile = TIMING_LAWS["s_curve"](TimingSpec(LENGTH, ANGLE, duration=2.0))
    assert profile.duration == 2.0 and float(profile(2.0)) == 1.0
    # A jerk limit the duration cannot keep: Infeasible naming the shortest duration.
    with pytest.raises(Infeasible) as err:
        TIMING_LAWS["s_curve"](TimingSpec(LENGTH, ANGLE, duration=0.2, max_linear_jerk=0.1))
    assert err.value.extra["min_duration"] > 0.2


def test_s_curve_law_needs_a_speed() -> None:
    with pytest.raises(InputError):
        TIMING_LAWS["s_curve"](TimingSpec(LENGTH, 0.0))


UR5 = registry.get("ur5")
UR5_HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])


def _line_task(**kw) -> tuple[CartesianTask, np.ndarray, np.ndarray]:
    T0 = UR5.fk(UR5_HOME)
    Tg = T0.copy()
    Tg[:3, 3] += np.array([0.15, -0.1, 0.05])
    task = CartesianTask(robot=UR5, q_start=UR5_HOME, T_goal=Tg, sample_period=0.004, **kw)
    return task, T0, Tg


def _path_parameter(traj, T0, Tg) -> np.ndarray:
    d = Tg[:3, 3] - T0[:3, 3]
    return (UR5.fk_many(traj.positions)[:, :3, 3] - T0[:3, 3]) @ d / (d @ d)


@pytest.mark.parametrize("method", ["sampled", "bounded_deviation", "resolved_rate_dls"])
def test_s_curve_line_has_continuous_path_acceleration(method: str) -> None:
    jerk = 2.0
    task, T0, Tg = _line_task(speed_profile="s_curve", max_linear_jerk=jerk)
    traj = plan(task, method).trajectory
    length = float(np.linalg.norm(Tg[:3, 3] - T0[:3, 3]))
    s, dt = _path_parameter(traj, T0, Tg), np.diff(traj.times)
    assert np.allclose(dt[:-1], 0.004, atol=1e-12)
    # Every 5th point (h = 0.02 s, so IK's 1e-10 m of noise stays below 1e-3 of the bound).
    # Third differences of s(t) are averages of s''' (a B-spline average): within the jerk
    # limit; second differences (s'') change by at most jerk * h per step: continuous.
    h, s = 0.02, s[:-1:5]
    third = np.diff(s, 3) / h**3
    sdd = np.diff(s, 2) / h**2
    # s(t) itself is jerk-limited exactly; the tool's projection on the line also carries the
    # path's own deviation: knots on a spline (bounded_deviation), the feedback term (DLS).
    tol = {"sampled": 2e-3, "bounded_deviation": 1e-2, "resolved_rate_dls": 2e-2}[method]
    assert length * np.abs(third).max() <= jerk * (1 + tol)
    assert length * np.abs(np.diff(sdd)).max() <= jerk * h * (1 + tol)
    assert length * np.abs(third).max() >= 0.9 * jerk  # the jerk limit is what shapes it
    assert np.all(np.abs(traj.velocities) <= UR5.velocity_limits * (1 + 1e-6))
    assert np.all(np.abs(traj.accelerations) <= UR5.acceleration_limits * (1 + 1e-6))
    np.testing.assert_allclose(UR5.fk(traj.positions[-1])[:3, 3], Tg[:3, 3], atol=1e-4)


def test_trapezoid_has_jumps_the_s_curve_removes() -> None:
    """The control: the default profile's s'' jumps at the start (the test above can fail)."""
    task, T0, Tg = _line_task()
    traj = plan(task, "sampled").trajectory
    length = float(np.linalg.norm(Tg[:3, 3] - T0[:3, 3]))
    sdd = np.diff(_path_parameter(traj, T0, Tg)[:-1:5], 2) / 0.02**2
    assert length * np.abs(np.diff(sdd)).max() > 0.3 * DEFAULT_LINEAR_ACCELERATION


def test_s_curve_fixed_duration_is_exact() -> None:
    task, _, Tg = _line_task(speed_profile="s_curve", duration=2.0)
    traj = plan(task, "sampled").trajectory
    assert traj.duration == 2.0
    np.testing.assert_allclose(UR5.fk(traj.positions[-1]), Tg, atol=1e-9)


def test_bad_speed_profile_and_jerk_are_input_errors() -> None:
    task, _, _ = _line_task(speed_profile="bang_bang")
    with pytest.raises(InputError) as err:
        plan(task, "sampled")
    assert err.value.field == ("speed_profile",)
    task, _, _ = _line_task(speed_profile="s_curve", max_angular_jerk=-1.0)
    with pytest.raises(InputError) as err:
        plan(task, "sampled")
    assert err.value.field == ("max_angular_jerk",)
