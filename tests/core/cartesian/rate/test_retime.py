"""The re-timing of a rate controller's clock for the joints' accelerations (``retime``): the
measured acceleration ratio against closed-form ramps, and when no new timing is made."""

from __future__ import annotations

import numpy as np
import pytest

from core.cartesian.rate.retime import WINDOW, joint_timing, peak_acceleration_ratio
from core.cartesian.task import CartesianTask
from tests.core.conftest import xy
from tests.toy_kinematics import ToyPlanar2R


@pytest.mark.parametrize("dt", [1e-3, 4e-3, 0.05])
def test_ratio_of_a_ramp_is_its_slope_over_the_limit(dt: float) -> None:
    """Rates ramping at (1.5, -0.5) rad/s^2 then holding: the ratio to limits (2, 0.25) is
    max(0.75, 2.0) = 2 at any tick, whatever the window."""
    t = np.arange(400) * dt
    ramp = np.minimum(t, 100 * dt)[:, None] * np.array([1.5, -0.5])
    ratio = peak_acceleration_ratio(ramp, dt, np.array([2.0, 0.25]))
    assert ratio == pytest.approx(2.0, rel=1e-9)


def test_tick_noise_shorter_than_the_window_is_averaged() -> None:
    """A single-tick spike of 1e-4 rad/s at 1 ms counts as 1e-4 / WINDOW, not 1e-4 / 1 ms."""
    rates = np.zeros((200, 1))
    rates[100] = 1e-4
    ratio = peak_acceleration_ratio(rates, 1e-3, np.array([1.0]))
    assert ratio == pytest.approx(1e-4 / WINDOW, rel=1e-9)


def test_no_new_timing_with_a_duration_or_a_short_run() -> None:
    robot = ToyPlanar2R()
    q0 = np.array([0.3, 1.2])
    task = CartesianTask(robot, q0, xy(1.0, 1.0), duration=1.0)
    line = task.line()
    s = np.linspace(0.0, 1.0, 50)
    q = q0 + s[:, None] * 0.1
    assert joint_timing(task, line, s, q) is None
    free = CartesianTask(robot, q0, xy(1.0, 1.0), max_linear_speed=0.1)
    assert joint_timing(free, line, s * 0.5, q) is None  # did not reach s = 1
    timing = joint_timing(free, line, s, q)
    assert timing is not None and timing.end == 1.0
    assert float(timing.profile(timing.duration)) == pytest.approx(1.0)
