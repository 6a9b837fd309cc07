"""The one joint-limit test of the Cartesian planners: the slack is LIMIT_SLACK of the range (at
least 1 rad) for positions and of the limit for speeds, and nothing else passes."""

from __future__ import annotations

import numpy as np

from core.limits import LIMIT_SLACK, inside, outside, over_speed, worst_joint

LIMITS = np.array([[-2.0, 2.0], [-0.25, 0.25]])  # ranges 4 rad and 0.5 rad (slack on 1 rad)


def test_position_slack_is_relative_to_the_range_at_least_one() -> None:
    slack = LIMIT_SLACK * np.array([4.0, 1.0])
    edge = LIMITS[:, 1] + slack
    assert inside(edge, LIMITS)
    for j in range(2):
        beyond = edge.copy()
        beyond[j] = np.nextafter(edge[j] + slack[j] * 1e-3, np.inf)
        assert not inside(beyond, LIMITS)
        np.testing.assert_array_equal(outside(beyond, LIMITS), np.arange(2) == j)
        below = LIMITS[:, 0].copy()
        below[j] -= 1e-3
        assert worst_joint(below, LIMITS) == j


def test_inside_is_per_configuration() -> None:
    q = np.array([[0.0, 0.0], [2.1, 0.0], [0.0, -0.3]])
    np.testing.assert_array_equal(inside(q, LIMITS), [True, False, False])


def test_speed_slack_is_relative_to_the_limit() -> None:
    vmax = np.array([1.0, 3.0])
    at = vmax * (1.0 + LIMIT_SLACK)
    assert not over_speed(at, vmax).any() and not over_speed(-at, vmax).any()
    np.testing.assert_array_equal(over_speed(at * (1.0 + 1e-12), vmax), [True, True])
