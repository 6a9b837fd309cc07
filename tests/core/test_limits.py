"""The one set of joint-limit checks: masks with their slacks, the raising checks built on them,
and the jerk limits."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import InputError, JointLimit, JointRateLimit
from core.limits import (
    LIMIT_SLACK,
    JointLimits,
    check_positions,
    check_rates,
    outside,
    over_rate_limit,
)

NAMES = ("a", "b")
POSITION = np.array([[-1.0, 1.0], [0.0, 2.0]])


def test_position_mask_has_the_one_slack_of_every_planner() -> None:
    """Was an absolute 1e-9 here and LIMIT_SLACK of the range in the Cartesian planners (issue
    23: one check, one slack): both joints span 2, so the slack is 2 LIMIT_SLACK."""
    slack = 2.0 * LIMIT_SLACK
    q = np.array(
        [
            [1.0 + 0.5 * slack, 2.0],
            [-1.0, -2.0 * slack],
            [1.0 + 2.0 * slack, 0.0],
        ]
    )
    np.testing.assert_array_equal(
        outside(q, POSITION), [[False, False], [False, True], [True, False]]
    )
    limits = JointLimits(position=POSITION)
    with pytest.raises(JointLimit) as err:
        check_positions(q, limits, NAMES, times=np.array([0.0, 0.5, 1.0]))
    assert err.value.joint == 1 and "t=0.5" in str(err.value)  # the first row at fault
    with pytest.raises(JointLimit) as err:
        check_positions(q[1:2], limits, NAMES, field=("start", "positions"))
    assert err.value.field == ("start", "positions", 1)


def test_rate_mask_has_a_relative_slack() -> None:
    limit = np.array([2.0, np.inf])
    values = np.array([[2.0 * (1 + 0.5 * LIMIT_SLACK), -1e300], [-2.0 * (1 + 2 * LIMIT_SLACK), 0]])
    np.testing.assert_array_equal(over_rate_limit(values, limit), [[False, False], [True, False]])


def test_check_rates_names_the_kind_and_skips_unknown_limits() -> None:
    limits = JointLimits(velocity=np.array([1.0, 1.0]), jerk=np.array([10.0, 5.0]))
    check_rates(np.array([1.0, 0.5]), np.array([1e9, 1e9]), limits, NAMES)  # no acceleration limit
    with pytest.raises(JointRateLimit) as err:
        check_rates(np.array([1.0, 0.5]), None, limits, NAMES, peak_jerk=np.array([1.0, 6.0]))
    assert err.value.joint == 1 and err.value.extra["limit"] == "jerk"
    assert err.value.extra["ratio"] == pytest.approx(1.2)


@pytest.mark.parametrize(
    "jerk", [np.array([1.0]), np.array([1.0, 0.0]), np.array([np.nan, 1.0]), np.ones((2, 1))]
)
def test_bad_jerk_limits_name_the_field(jerk: np.ndarray) -> None:
    with pytest.raises(InputError) as err:
        JointLimits(jerk=jerk).validate(2)
    assert err.value.field == ("limits", "jerk")


def test_limits_of_a_robot_model() -> None:
    class Chain:
        position_limits = POSITION
        velocity_limits = np.array([1.0, 2.0])
        acceleration_limits = np.array([3.0, 4.0])

    limits = JointLimits.of(Chain(), jerk=np.array([5.0, 6.0]))
    np.testing.assert_array_equal(limits.position, POSITION)
    np.testing.assert_array_equal(limits.maxima(2), ([1.0, 2.0], [3.0, 4.0]))
    np.testing.assert_array_equal(limits.jerk, [5.0, 6.0])
    limits.validate(2)
