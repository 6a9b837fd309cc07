"""Splines: equal to scipy's CubicSpline, C2 at the knots, boundary conditions (and scipy's 2 and 3
point fallbacks), time allocation under limits checked densely, and the input checks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from core.budget import Deadline
from core.errors import Infeasible, InputError, JointLimit, JointRateLimit, TimeBudgetExceeded
from core.joint.profiles.polynomial import PolynomialProfile
from core.joint.splines import BOUNDARIES, SplineProfile, allocate_times, plan_spline
from core.limits import JointLimits

RNG_SEED = 4242


def random_waypoints(rng: np.random.Generator, n: int | None = None, dof: int | None = None):
    n = int(rng.integers(2, 12)) if n is None else n
    dof = int(rng.integers(1, 7)) if dof is None else dof
    return rng.uniform(-3, 3, (n, dof))


def random_times(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(rng.uniform(0.1, 3.0, n - 1))])


def scipy_spline(times, q, boundary, v0=None, v1=None) -> CubicSpline:
    dof = q.shape[1]
    if boundary == "clamped":
        v0 = np.zeros(dof) if v0 is None else v0
        v1 = np.zeros(dof) if v1 is None else v1
        return CubicSpline(times, q, bc_type=((1, v0), (1, v1)), axis=0)
    return CubicSpline(times, q, bc_type=boundary, axis=0)


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_equals_scipy_at_the_returned_times(boundary: str) -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(60):
        q = random_waypoints(rng)
        times = random_times(rng, q.shape[0])
        ends = {}
        if boundary == "clamped" and rng.random() < 0.5:
            ends = {"start_velocity": rng.uniform(-1, 1, q.shape[1])}
        plan = plan_spline(q, times=times, boundary=boundary, samples=501, **ends)
        ref = scipy_spline(times, q, boundary, ends.get("start_velocity"))
        traj = plan.trajectory
        for order, got in enumerate((traj.positions, traj.velocities, traj.accelerations)):
            want = ref(traj.times, order)
            scale = 1.0 + np.abs(want).max()
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_c2_at_the_knots_and_through_every_waypoint(boundary: str) -> None:
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(40):
        q = random_waypoints(rng, n=int(rng.integers(3, 12)))
        times = random_times(rng, q.shape[0])
        prof = SplineProfile(times, q, boundary)
        np.testing.assert_allclose(prof(times, 0), q, atol=1e-12)
        inner = times[1:-1]
        for order in (0, 1, 2):
            left = prof(inner - 1e-9, order)
            right = prof(inner + 1e-9, order)
            scale = 1.0 + np.abs(prof(times, order)).max()
            np.testing.assert_allclose(left, right, rtol=0, atol=1e-6 * scale)
        # piece by piece: each piece at its right end equals the next piece at its left end
        c, h = prof.spline.c, np.diff(times)[:, None]
        c0, c1, c2, c3 = c[0], c[1], c[2], c[3]
        ends = (
            c0 * h**3 + c1 * h**2 + c2 * h + c3,  # position
            3 * c0 * h**2 + 2 * c1 * h + c2,  # velocity
            6 * c0 * h + 2 * c1,  # acceleration
        )
        starts = (c3, c2, 2 * c1)
        for end, start in zip(ends, starts, strict=True):
            np.testing.assert_allclose(end[:-1], start[1:], rtol=1e-9, atol=1e-9)


def test_boundary_conditions() -> None:
    rng = np.random.default_rng(RNG_SEED + 2)
    q = random_waypoints(rng, n=6, dof=3)
    times = random_times(rng, 6)
    v0, v1 = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
    ends = np.array([0.0, times[-1]])
    clamped = SplineProfile(times, q, "clamped", v0, v1)
    np.testing.assert_array_equal(clamped(ends, 1), [v0, v1])
    np.testing.assert_allclose(clamped.spline(ends, 1), [v0, v1], atol=1e-12)
    np.testing.assert_array_equal(SplineProfile(times, q, "clamped")(ends, 1), 0.0)
    natural = SplineProfile(times, q, "natural")
    np.testing.assert_allclose(natural.spline(ends, 2), 0.0, atol=1e-9)
    knot = SplineProfile(times, q, "not-a-knot")
    # third derivative continuous across the first and last interior knots
    for t in (times[1], times[-2]):
        np.testing.assert_allclose(knot(np.array([t - 1e-7]), 3), knot(np.array([t + 1e-7]), 3))


def test_two_and_three_waypoint_fallbacks() -> None:
    q2 = np.array([[0.0, 1.0], [2.0, -1.0]])
    t2 = np.array([0.0, 2.0])
    for boundary in ("natural", "not-a-knot"):  # the straight line
        prof = SplineProfile(t2, q2, boundary)
        t = np.linspace(0, 2, 11)
        np.testing.assert_allclose(prof(t, 1), np.tile([1.0, -1.0], (11, 1)), atol=1e-12)
        np.testing.assert_allclose(prof(t, 2), 0.0, atol=1e-12)
    # clamped through 2 points at rest is the cubic rest-to-rest profile
    cubic = PolynomialProfile(q2[0], q2[1], 2.0, np.zeros(2), np.zeros(2))
    t = np.linspace(0, 2, 11)
    for order in (0, 1, 2):
        spline = SplineProfile(t2, q2, "clamped")(t, order)
        np.testing.assert_allclose(spline, cubic(t, order), rtol=0, atol=1e-12)
    # not-a-knot through 3 points: one parabola
    q3, t3 = np.array([[0.0], [1.0], [0.0]]), np.array([0.0, 1.0, 3.0])
    prof = SplineProfile(t3, q3, "not-a-knot")
    np.testing.assert_allclose(prof.spline.c[0], 0.0, atol=1e-12)
    t = np.linspace(0, 3, 31)
    np.testing.assert_allclose(prof(t, 2), np.full((31, 1), prof(t[:1], 2)[0, 0]), atol=1e-12)


def test_segment_peaks_are_exact() -> None:
    rng = np.random.default_rng(RNG_SEED + 3)
    for boundary in BOUNDARIES:
        q = random_waypoints(rng, n=8, dof=4)
        times = random_times(rng, 8)
        prof = SplineProfile(times, q, boundary)
        vel, acc = prof.segment_peaks()
        # dense samples plus the knots (the acceleration of a cubic piece peaks at an end)
        t = np.union1d(np.linspace(0, times[-1], 200_001), times)
        dense_v, dense_a = np.abs(prof(t, 1)).max(axis=0), np.abs(prof(t, 2)).max(axis=0)
        assert np.all(dense_v <= vel.max(axis=0) * (1 + 1e-12))
        np.testing.assert_allclose(vel.max(axis=0), dense_v, rtol=1e-8)
        np.testing.assert_allclose(acc.max(axis=0), dense_a, rtol=1e-12)


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_allocated_times_respect_limits_densely_and_bind(boundary: str) -> None:
    rng = np.random.default_rng(RNG_SEED + 4)
    for _ in range(40):
        q = random_waypoints(rng)
        dof = q.shape[1]
        limits = JointLimits(rng.uniform(0.2, 3.0, dof), rng.uniform(0.5, 10.0, dof))
        ends = {}
        if boundary == "clamped" and rng.random() < 0.4:
            ends = {"goal_velocity": rng.uniform(-0.5, 0.5, dof) * limits.velocity}
        plan = plan_spline(q, boundary=boundary, limits=limits, samples=1001, **ends)
        prof = plan.profile
        t = np.linspace(0, prof.duration, 50_001)
        dense = np.concatenate(
            [
                np.abs(prof(t, 1)).max(axis=0) / limits.velocity,
                np.abs(prof(t, 2)).max(axis=0) / limits.acceleration,
            ]
        )
        vel, acc = prof.segment_peaks()
        exact = np.concatenate(
            [vel.max(axis=0) / limits.velocity, acc.max(axis=0) / limits.acceleration]
        )
        assert dense.max() <= 1 + 1e-9 and exact.max() <= 1 + 1e-9, (q, limits)
        if prof.duration > 1e-3:
            assert exact.max() >= 0.9, "the binding limit is not reached"
        assert np.all(np.diff(plan.knot_times) > 0)


def test_allocation_with_repeated_waypoints_and_one_limit() -> None:
    q = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 1.0], [0.0, 2.0]])
    for limits in (JointLimits(velocity=np.ones(2)), JointLimits(acceleration=np.ones(2))):
        knots = allocate_times(q, "clamped", limits)
        assert np.all(np.isfinite(knots)) and np.all(np.diff(knots) > 0)
    same = np.zeros((3, 2))
    plan = plan_spline(same, limits=JointLimits(np.ones(2), np.ones(2)))
    assert plan.trajectory.duration == pytest.approx(1e-3)


def test_input_checks_name_the_field() -> None:
    q = np.array([[0.0], [1.0], [0.5]])
    cases = [
        ({"times": np.array([0.0, 1.0])}, ("times",)),
        ({"times": np.array([0.5, 1.0, 2.0])}, ("times", 0)),
        ({"times": np.array([0.0, 1.0, 1.0])}, ("times", 2)),
        ({"boundary": "natural", "start_velocity": np.zeros(1)}, ("start_velocity",)),
        ({"boundary": "clamped", "goal_velocity": np.zeros(2)}, ("goal_velocity",)),
        ({"boundary": "periodic"}, ("boundary",)),
        ({}, ("limits",)),
    ]
    for kwargs, field in cases:
        with pytest.raises(InputError) as err:
            plan_spline(q, **kwargs)
        assert err.value.field == field, kwargs
    with pytest.raises(InputError) as err:
        plan_spline(np.array([[0.0]]), times=np.array([0.0]))
    assert err.value.field == ("waypoints",)


def test_limits_with_given_times_and_position_limits() -> None:
    q = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 0.0]])
    limits = JointLimits(np.ones(2), np.ones(2), np.array([[-1.0, 1.5], [-1.0, 1.0]]))
    with pytest.raises(JointLimit) as err:
        plan_spline(q, times=np.array([0.0, 5.0, 10.0]), limits=limits)
    assert err.value.field == ("waypoints", 2, 0)
    fast = JointLimits(np.ones(2), np.ones(2))
    with pytest.raises(JointRateLimit):
        plan_spline(q, times=np.array([0.0, 0.1, 0.2]), limits=fast)
    with pytest.raises(JointRateLimit) as err:
        plan_spline(q, limits=fast, start_velocity=np.array([0.0, 2.0]))
    assert err.value.field == ("start_velocity", 1)
    # overshoot between waypoints leaves the position limits
    tight = JointLimits(position=np.array([[-0.01, 1.0], [-1.0, 1.0]]))
    q2 = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    with pytest.raises(JointLimit) as err:
        plan_spline(q2, times=np.array([0.0, 1.0, 1.1, 3.0]), boundary="natural", limits=tight)
    assert err.value.sample is not None and err.value.joint == 0


def test_the_deadline_stops_allocation() -> None:
    deadline = Deadline(0.0)
    with pytest.raises(TimeBudgetExceeded):
        plan_spline(
            np.array([[0.0], [1.0]]), limits=JointLimits(np.ones(1), np.ones(1)), deadline=deadline
        )


def test_sample_equals_three_evaluations_in_and_out_of_order() -> None:
    """``SplineProfile.sample`` (one interval search, blocked Horner) equals ``profile(t, order)``
    for every boundary condition, at unsorted times, knots and ends included, past one block."""
    from core.joint.spline_profile import SAMPLE_BLOCK

    rng = np.random.default_rng(21)
    waypoints = np.cumsum(rng.uniform(-0.5, 0.5, (9, 3)), axis=0)
    knots = np.concatenate([[0.0], np.cumsum(rng.uniform(0.2, 1.0, 8))])
    t = np.concatenate([knots, rng.uniform(0.0, knots[-1], 2 * SAMPLE_BLOCK + 7)])
    rng.shuffle(t)
    for boundary in BOUNDARIES:
        profile = SplineProfile(knots, waypoints, boundary)
        for order, got in enumerate(profile.sample(t)):
            want = profile(t, order)
            assert got.shape == want.shape
            atol = 1e-12 * max(1.0, np.abs(want).max())
            np.testing.assert_allclose(got, want, rtol=0, atol=atol)
        ends = (t == 0.0) | (t == knots[-1])
        np.testing.assert_array_equal(profile.sample(t)[0][ends], profile(t)[ends])  # pinned


@pytest.mark.parametrize("speed", [1e-300, 1e-100, 1e-30])
@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_a_vanishing_speed_limit_is_infeasible_not_an_overflow(speed: float, boundary: str) -> None:
    # Issue 19 item 1: knot times from a 1e-300 rad/s limit overflowed to inf inside scipy.
    limits = JointLimits(velocity=np.array([speed]), acceleration=np.array([10.0]))
    with np.errstate(all="raise"), pytest.raises(Infeasible, match="more than 100000 s"):
        plan_spline(np.array([[0.0], [0.5]]), boundary=boundary, limits=limits, samples=5)
