"""The 200 rule of every method (issue 19, item 6): a returned plan is within its tolerance between
its points and within the robot's acceleration limits, else a 422 that names the fix; densified or
slowed down where the request leaves room; ``allow_violations`` accepts it with a warning."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from core.cartesian.plan import plan
from core.errors import Infeasible, JointRateLimit
from core.trajectory import DEFAULT_SAMPLE_PERIOD
from tests.core.conftest import independent_deviation, toy_task


def test_sparse_points_over_the_tolerance_are_infeasible_unless_allowed() -> None:
    task = toy_task(duration=0.6, position_tolerance=1e-5, sample_period=DEFAULT_SAMPLE_PERIOD)
    with pytest.raises(Infeasible, match="sample_period") as err:
        plan(task, "sampled")
    assert err.value.extra["max_position_deviation"] > 1e-5 and 0.0 <= err.value.s <= 1.0
    result = plan(replace(task, allow_violations=True), "sampled")
    assert any("strays" in w for w in result.warnings)
    position, _ = independent_deviation(task.robot, task.line(), result.trajectory)
    assert position > 1e-5  # the accepted plan really is over the tolerance


def test_default_sampling_is_densified_until_within_the_tolerance() -> None:
    task = toy_task(duration=0.6, position_tolerance=1e-6)
    result = plan(task, "sampled")
    assert len(result.trajectory.times) > 0.6 / DEFAULT_SAMPLE_PERIOD + 1
    position, _ = independent_deviation(task.robot, task.line(), result.trajectory)
    assert position <= 1e-6 * (1 + 1e-6)
    assert result.deviation.max_position <= 1e-6


def test_a_duration_too_short_for_the_accelerations_names_the_shortest_one() -> None:
    task = toy_task(duration=0.45)  # speeds within the limits, accelerations not
    with pytest.raises(JointRateLimit, match="accelerate") as err:
        plan(task, "sampled")
    assert err.value.field == ("duration",) and err.value.extra["limit"] == "acceleration"
    min_duration = err.value.extra["min_duration"]
    assert min_duration > 0.45
    ok = plan(replace(task, duration=1.001 * min_duration), "sampled")
    ratio = ok.trajectory.peak_acceleration / np.asarray(task.robot.acceleration_limits)
    assert ratio.max() <= 1.0 + 1e-6
    allowed = plan(replace(task, allow_violations=True), "sampled")
    assert any("accelerations reach" in w for w in allowed.warnings)


@pytest.mark.parametrize("method", ["resolved_rate", "resolved_rate_dls", "bounded_deviation"])
def test_every_method_obeys_the_same_rule(method) -> None:
    task = toy_task(duration=2.0, samples=3)
    try:
        result = plan(task, method)
    except (Infeasible, JointRateLimit):
        return
    assert result.deviation.max_position <= task.position_tolerance * (1 + 1e-6)
    ratio = result.trajectory.peak_acceleration / np.asarray(task.robot.acceleration_limits)
    assert ratio.max() <= 1.0 + 1e-6
