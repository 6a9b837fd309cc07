"""Durations from limits: closed forms, the numeric search, the checks; and ``plan_joint``, which
uses them: limits respected wherever the duration is chosen, the binding limit reached, errors."""

from __future__ import annotations

import numpy as np
import pytest

from core.budget import Deadline
from core.errors import Infeasible, InputError, JointLimit, JointRateLimit, TimeBudgetExceeded
from core.joint import durations as timing
from core.joint.durations import shortest_feasible
from core.joint.point_to_point import PROFILES as REGISTRY
from core.joint.point_to_point import PointToPoint, plan_joint
from core.limits import JointLimits

PROFILES = ("linear", "cubic", "quintic", "trapezoidal")
"""The profiles timed by velocity and acceleration limits alone (``jerk_limited`` also needs jerk:
tests/core/joint/profiles/test_jerk_limited.py)."""

RNG_SEED = 7301


def random_limits(rng: np.random.Generator, dof: int) -> JointLimits:
    return JointLimits(rng.uniform(0.2, 3.0, dof), rng.uniform(0.5, 10.0, dof))


def ratios(plan, limits: JointLimits, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Exact and sampled peak/limit ratios, each ``(dof,)`` velocity then acceleration stacked."""
    vel, acc, _ = plan.profile.peaks()
    traj = plan.trajectory
    exact = np.concatenate([vel / limits.velocity, acc / limits.acceleration])
    sampled = np.concatenate(
        [traj.peak_velocity / limits.velocity, traj.peak_acceleration / limits.acceleration]
    )
    if kind == "linear":  # judged on velocity only; its end steps are declared
        exact[len(vel) :] = sampled[len(vel) :] = 0.0
    return exact, sampled


@pytest.mark.parametrize("kind", PROFILES)
def test_rest_to_rest_limits_hold_and_bind(kind: str) -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(150):
        dof = int(rng.integers(1, 8))
        motion = PointToPoint.create(rng.uniform(-3, 3, dof), rng.uniform(-3, 3, dof))
        limits = random_limits(rng, dof)
        plan = plan_joint(kind, motion, limits, samples=int(rng.integers(2, 400)))
        exact, sampled = ratios(plan, limits, kind)
        assert exact.max() <= 1 + 1e-9 and sampled.max() <= 1 + 1e-9, (kind, motion, limits)
        assert exact.max() >= 1 - 1e-9, "the binding limit is not reached"


@pytest.mark.parametrize("kind", ["cubic", "quintic"])
def test_boundary_rates_shortest_duration_is_found_numerically(kind: str) -> None:
    rng = np.random.default_rng(RNG_SEED + 1)
    solved = 0
    for _ in range(60):
        dof = int(rng.integers(1, 6))
        limits = random_limits(rng, dof)
        vel = rng.uniform(-0.7, 0.7, (2, dof)) * limits.velocity
        acc = rng.uniform(-0.3, 0.3, (2, dof)) * limits.acceleration
        accs = (acc[0], acc[1]) if kind == "quintic" else (None, None)
        motion = PointToPoint.create(
            rng.uniform(-3, 3, dof), rng.uniform(-3, 3, dof), vel[0], vel[1], *accs
        )
        try:
            plan = plan_joint(kind, motion, limits, samples=2001)
        except JointRateLimit:
            # Truly infeasible: no duration on a fine scan keeps within the limits.
            durations = np.geomspace(timing.MIN_DURATION, timing.MAX_DURATION, 4001)
            vel_pk, acc_pk = REGISTRY[kind].build(motion, durations[:, None], np.inf).peaks()[:2]
            excess = np.maximum(vel_pk / limits.velocity, acc_pk / limits.acceleration)
            assert np.all(excess.max(axis=1) > 1.0), motion
            continue
        solved += 1
        exact, sampled = ratios(plan, limits, kind)
        assert exact.max() <= 1 + 1e-12 and sampled.max() <= 1 + 1e-9
        # verified densely, and the shortest: a hair shorter breaks a limit
        T = plan.trajectory.duration
        if T > timing.MIN_DURATION:
            assert exact.max() >= 0.9
            shorter = plan_joint(kind, motion, duration=T * (1 - 1e-6)).profile.peaks()
            worse = np.concatenate([shorter[0] / limits.velocity, shorter[1] / limits.acceleration])
            assert worse.max() > 1.0
    assert solved >= 30


def test_boundary_conditions_no_duration_can_honour() -> None:
    # At the speed limit and still accelerating: every duration exceeds the limit right after 0.
    motion = PointToPoint.create([0.0], [1.0], [1.0], [0.0], [1.0], [0.0])
    limits = JointLimits(np.array([1.0]), np.array([2.0]))
    with pytest.raises(JointRateLimit):
        plan_joint("quintic", motion, limits)


def test_closed_forms() -> None:
    dist, v, a = np.array([2.0, 0.5]), np.array([1.0, 1.0]), np.array([1.0, 4.0])
    assert timing.linear_duration(dist, v) == 2.0
    assert timing.cubic_duration(dist, v, a) == pytest.approx(max(3.0, np.sqrt(12.0)))
    assert timing.quintic_duration(dist, v, a) == pytest.approx(
        max(1.875 * 2, np.sqrt(10 / np.sqrt(3) * 2))
    )
    # joint 0 cruises (2 >= 1^2/1): 2/1 + 1/1; joint 1 triangle (0.5 < 1/4? no: cruise 0.5/1+1/4)
    np.testing.assert_allclose(timing.trapezoidal_joint_durations(dist, v, a), [3.0, 0.75])
    assert timing.trapezoidal_joint_durations(np.array([0.1]), v[:1], a[:1])[0] == pytest.approx(
        2 * np.sqrt(0.1)
    )


def test_shortest_feasible_on_a_known_function() -> None:
    assert shortest_feasible(lambda x: 2.0 / x - 1.0) == pytest.approx(2.0, rel=1e-12)
    assert shortest_feasible(lambda x: 2.0 / x - 1.0) >= 2.0
    assert shortest_feasible(lambda x: np.ones_like(x)) is None
    assert shortest_feasible(lambda x: -np.ones_like(x)) == timing.MIN_DURATION


def test_shortest_feasible_finds_an_island_narrower_than_the_grid() -> None:
    # feasible only on [10, 10.5]: a factor 1.05, under the grid's step of 1.12
    def excess(x: np.ndarray) -> np.ndarray:
        return np.abs(x - 10.25) - 0.25

    assert shortest_feasible(excess) == pytest.approx(10.0, rel=1e-12)
    # and an island before a wide feasible stretch is preferred
    assert shortest_feasible(lambda x: np.minimum(excess(x), 100.0 - x)) == pytest.approx(10.0)


def test_a_given_duration_over_the_limits_names_the_shortest() -> None:
    motion = PointToPoint.create([0.0, 0.0], [1.0, 2.0])
    limits = JointLimits(np.array([1.0, 1.0]), np.array([10.0, 10.0]))
    with pytest.raises(JointRateLimit) as err:
        plan_joint("quintic", motion, limits, duration=1.0)
    assert err.value.joint == 1 and "3.75 s" in err.value.detail
    # trapezoid too short for the acceleration limit
    with pytest.raises(JointRateLimit) as err:
        plan_joint("trapezoidal", motion, limits, duration=0.5)
    assert err.value.extra["limit"] in ("velocity", "acceleration")
    assert plan_joint("quintic", motion, limits, duration=3.75).trajectory.duration == 3.75


def test_missing_limits_name_the_field() -> None:
    motion = PointToPoint.create([0.0], [1.0])
    for kind, limits, field in (
        ("quintic", JointLimits(), ("limits",)),
        ("linear", JointLimits(acceleration=np.array([1.0])), ("limits", "velocity")),
        ("trapezoidal", JointLimits(velocity=np.array([1.0])), ("limits", "acceleration")),
    ):
        with pytest.raises(InputError) as err:
            plan_joint(kind, motion, limits)
        assert err.value.field == field
    # one limit is enough for cubic/quintic
    plan_joint("cubic", motion, JointLimits(acceleration=np.array([1.0])))


def test_no_motion_gets_the_minimum_duration() -> None:
    motion = PointToPoint.create([0.5, 0.5], [0.5, 0.5])
    limits = JointLimits(np.ones(2), np.ones(2))
    for kind in PROFILES:
        traj = plan_joint(kind, motion, limits).trajectory
        assert traj.duration == timing.MIN_DURATION
        np.testing.assert_array_equal(traj.positions, 0.5)


def test_over_the_longest_duration_is_infeasible() -> None:
    motion = PointToPoint.create([0.0], [1e4])
    with pytest.raises(Infeasible) as err:
        plan_joint("linear", motion, JointLimits(velocity=np.array([1e-3])))
    assert err.value.field == ("limits",)


def test_boundary_checks() -> None:
    limits = JointLimits(np.array([1.0, 1.0]), np.array([1.0, 1.0]))
    move = PointToPoint.create([0, 0], [1, 1], [0, 0.5], [0, 0])
    for kind in ("linear", "trapezoidal"):
        with pytest.raises(InputError) as err:
            plan_joint(kind, move, limits)
        assert err.value.field == ("start", "velocities")
    accel = PointToPoint.create([0, 0], [1, 1], None, None, None, [0, 0.5])
    with pytest.raises(InputError) as err:
        plan_joint("cubic", accel, limits)
    assert err.value.field == ("goal", "accelerations")
    fast = PointToPoint.create([0, 0], [1, 1], [0, 2.0], [0, 0])
    with pytest.raises(JointRateLimit) as err:
        plan_joint("cubic", fast, limits)
    assert err.value.field == ("start", "velocities", 1) and err.value.joint == 1


def test_input_lengths_name_the_field() -> None:
    with pytest.raises(InputError) as err:
        PointToPoint.create([0, 0], [1, 1, 1])
    assert err.value.field == ("goal", "positions")
    with pytest.raises(InputError) as err:
        PointToPoint.create([0, 0], [1, 1], [0.0])
    assert err.value.field == ("start", "velocities")
    with pytest.raises(InputError) as err:
        plan_joint("cubic", PointToPoint.create([0], [1]), JointLimits(np.ones(2)))
    assert err.value.field == ("limits", "velocity")
    with pytest.raises(InputError) as err:
        plan_joint("cubic", PointToPoint.create([0], [1]), JointLimits(np.array([-1.0])))
    assert err.value.field == ("limits", "velocity")


def test_position_limits() -> None:
    position = np.array([[-1.0, 1.0], [-1.0, 1.0]])
    limits = JointLimits(np.full(2, 5.0), np.full(2, 50.0), position)
    with pytest.raises(JointLimit) as err:
        plan_joint("quintic", PointToPoint.create([0, 0], [0.5, 1.5]), limits)
    assert err.value.field == ("goal", "positions", 1) and err.value.joint == 1
    # a cubic whose start velocity overshoots the limit between the ends
    overshoot = PointToPoint.create([0, 0], [0.9, 0], [4.0, 0], [0, 0])
    with pytest.raises(JointLimit) as err:
        plan_joint("cubic", overshoot, limits, duration=2.0)
    assert err.value.joint == 0 and err.value.sample is not None and err.value.field is None


def test_too_many_points_before_allocating() -> None:
    from core.errors import TooLarge

    motion = PointToPoint.create([0.0], [1.0])
    with pytest.raises(TooLarge):
        plan_joint("cubic", motion, duration=1e5, sample_period=1e-4)


def test_a_given_duration_under_vanishing_limits_names_no_absurd_duration() -> None:
    motion = PointToPoint.create([0.0], [0.5])
    limits = JointLimits(np.array([1e-300]), np.array([1e-300]))
    for kind in PROFILES:
        with np.errstate(over="raise", invalid="raise"), pytest.raises(JointRateLimit) as err:
            plan_joint(kind, motion, limits, duration=1.0)
        assert "more than 100000 s" in str(err.value), (kind, str(err.value))


def test_an_expired_deadline_stops_the_plan() -> None:
    motion = PointToPoint.create([0.0], [1.0])
    with pytest.raises(TimeBudgetExceeded):
        plan_joint("quintic", motion, duration=1.0, deadline=Deadline(0.0))
