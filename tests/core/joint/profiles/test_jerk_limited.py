"""jerk_limited (Ruckig): end conditions, limits over a dense resampling, time-optimality against
Ruckig called directly, synchronization, a given duration, exact peaks, and every failure as
``Infeasible``. Seeded random problems print their input when they fail."""

from __future__ import annotations

import numpy as np
import pytest
import ruckig

from core.errors import Infeasible, InputError, PlanningError
from core.joint.point_to_point import PointToPoint, plan_joint
from core.joint.profiles.jerk_limited import JerkLimitedProfile
from core.limits import JointLimits

RNG_SEED = 17017
DENSE = 10_001


def random_problem(rng: np.random.Generator, rest: bool = False):
    dof = int(rng.integers(1, 8))
    limits = JointLimits(
        velocity=rng.uniform(0.5, 3.0, dof),
        acceleration=rng.uniform(1.0, 10.0, dof),
        jerk=rng.uniform(5.0, 100.0, dof),
    )
    q0, q1 = rng.uniform(-2, 2, dof), rng.uniform(-2, 2, dof)
    if rest:
        return PointToPoint.create(q0, q1), limits
    # Boundary states well inside the limits (a = 0 at the goal side with some velocity, so the
    # goal state is reachable: Ruckig rejects goal states that must overshoot the velocity limit).
    v0 = rng.uniform(-0.5, 0.5, dof) * limits.velocity
    a0 = rng.uniform(-0.3, 0.3, dof) * limits.acceleration
    v1 = rng.uniform(-0.5, 0.5, dof) * limits.velocity
    return PointToPoint.create(q0, q1, v0, v1, a0, np.zeros(dof)), limits


def ruckig_direct(motion: PointToPoint, limits: JointLimits, duration: float | None = None):
    dof = motion.dof
    inp = ruckig.InputParameter(dof)
    inp.current_position, inp.target_position = motion.start.positions, motion.goal.positions
    inp.current_velocity, inp.target_velocity = motion.start.velocities, motion.goal.velocities
    inp.current_acceleration = motion.start.accelerations
    inp.target_acceleration = motion.goal.accelerations
    inp.max_velocity, inp.max_acceleration = limits.velocity, limits.acceleration
    inp.max_jerk = limits.jerk
    if duration is not None:
        inp.minimum_duration = duration
    traj = ruckig.Trajectory(dof)
    ruckig.Ruckig(dof).calculate(inp, traj)
    return traj


@pytest.mark.parametrize("rest", [True, False])
def test_random_problems_end_exactly_within_limits_time_optimal(rest: bool) -> None:
    rng = np.random.default_rng(RNG_SEED + rest)
    for _ in range(40):
        motion, limits = random_problem(rng, rest)
        plan = plan_joint("jerk_limited", motion, limits, samples=int(rng.integers(2, 300)))
        traj, profile = plan.trajectory, plan.profile
        case = (motion, limits)
        # End conditions (exact boundary states at the returned ends).
        for row, state in ((0, motion.start), (-1, motion.goal)):
            np.testing.assert_allclose(traj.positions[row], state.positions, rtol=0, atol=1e-9)
            np.testing.assert_allclose(traj.velocities[row], state.velocities, rtol=0, atol=1e-9)
            np.testing.assert_allclose(
                traj.accelerations[row], state.accelerations, rtol=0, atol=1e-9
            )
        # The profile itself reaches the goal (not only the pinned sample).
        T = profile.duration
        np.testing.assert_allclose(
            profile.evaluate(np.array([T]), (0,))[0][0],
            motion.goal.positions,
            atol=1e-9,
        )
        # Time-optimal: Ruckig's own duration.
        assert T == pytest.approx(ruckig_direct(motion, limits).duration, rel=1e-12), case
        # Limits over a dense resampling of the returned profile (1e-9 relative).
        t = np.linspace(0.0, T, DENSE)
        for order, limit in ((1, limits.velocity), (2, limits.acceleration), (3, limits.jerk)):
            peak = np.abs(profile(t, order)).max(axis=0)
            assert np.all(peak <= limit * (1 + 1e-9)), (order, peak / limit, case)
        # Exact peaks bound the dense samples from above, and are reached to within one grid
        # step times the next derivative's bound.
        step = t[1] - t[0]
        dense = [np.abs(profile(t, order)).max(axis=0) for order in (1, 2)]
        slopes = (limits.acceleration, limits.jerk)
        for exact, sampled, slope in zip(traj.peaks[:2], dense, slopes, strict=True):
            assert np.all(exact >= sampled - 1e-12), case
            assert np.all(exact <= sampled + slope * step + 1e-12), case
        jerks = profile(t, 3)
        assert np.all(traj.peak_jerk >= np.abs(jerks).max(axis=0) - 1e-12)


def test_sampling_equals_ruckig_at_time_and_its_derivatives_are_consistent() -> None:
    rng = np.random.default_rng(RNG_SEED + 7)
    motion, limits = random_problem(rng)
    plan = plan_joint("jerk_limited", motion, limits, samples=500)
    direct = ruckig_direct(motion, limits)
    t = np.linspace(0.0, direct.duration, 777)[1:-1]
    q, qd, qdd = plan.profile.sample(t)
    reference = np.array([np.concatenate(direct.at_time(x)) for x in t])
    dof = motion.dof
    np.testing.assert_allclose(q, reference[:, :dof], rtol=0, atol=1e-12)
    np.testing.assert_allclose(qd, reference[:, dof : 2 * dof], rtol=0, atol=1e-12)
    np.testing.assert_allclose(qdd, reference[:, 2 * dof :], rtol=0, atol=1e-12)
    # Central differences of positions and velocities (the profile is C2: error O(h^2 j')).
    h = 1e-6
    for order in (0, 1):
        fd = (plan.profile(t + h, order) - plan.profile(t - h, order)) / (2 * h)
        np.testing.assert_allclose(fd, plan.profile(t, order + 1), rtol=0, atol=1e-5)


def test_synchronized_every_joint_moves_until_the_end() -> None:
    motion = PointToPoint.create([0.0, 0.0, 0.0], [2.0, 0.2, -1.0])
    limits = JointLimits(np.ones(3), np.full(3, 2.0), jerk=np.full(3, 10.0))
    profile = plan_joint("jerk_limited", motion, limits).profile
    T = profile.duration
    # Each joint's seven phases last exactly T, and no joint is at rest at its goal before T.
    np.testing.assert_allclose(profile.phase_durations.sum(axis=1), T, rtol=1e-12)
    near_end = profile(np.array([0.99 * T]), 0)[0]
    assert np.all(np.abs(near_end - motion.goal.positions) > 1e-9)
    # The slowest joint alone sets T: it equals its independent minimum duration.
    independent = ruckig_direct(motion, limits).independent_min_durations
    assert T == pytest.approx(max(independent), rel=1e-12)
    assert min(independent) < 0.9 * T


def test_a_given_duration_is_exact_and_a_short_one_names_the_shortest() -> None:
    motion = PointToPoint.create([0.0, 0.5], [1.0, -0.5], [0.2, 0.0], [0.0, 0.1])
    limits = JointLimits(np.ones(2), np.full(2, 2.0), jerk=np.full(2, 10.0))
    shortest = plan_joint("jerk_limited", motion, limits).trajectory.duration
    plan = plan_joint("jerk_limited", motion, limits, duration=2.5 * shortest, sample_period=0.01)
    assert plan.trajectory.times[-1] == 2.5 * shortest
    np.testing.assert_allclose(plan.trajectory.positions[-1], motion.goal.positions, atol=1e-9)
    np.testing.assert_allclose(
        plan.profile(np.array([2.5 * shortest]), 0)[0], motion.goal.positions, atol=1e-9
    )
    with pytest.raises(Infeasible) as err:
        plan_joint("jerk_limited", motion, limits, duration=0.9 * shortest)
    assert f"{shortest:.6g} s" in str(err.value) and err.value.field == ("duration",)
    assert err.value.extra["min_duration"] == pytest.approx(shortest, rel=1e-12)


def test_unreachable_boundary_states_are_infeasible_with_the_reason() -> None:
    limits = JointLimits(np.ones(1), np.full(1, 2.0), jerk=np.full(1, 10.0))
    cases = {
        "start velocity over the limit": PointToPoint.create([0.0], [1.0], [1.5], [0.0]),
        "goal acceleration over the limit": PointToPoint.create(
            [0.0], [1.0], None, None, None, [3]
        ),
        "start state that must overshoot": PointToPoint.create([0.0], [1.0], [0.9], None, [1.9]),
        "goal state that must overshoot": PointToPoint.create(
            [0.0], [1.0], None, [0.9], None, [-1.9]
        ),
    }
    for what, motion in cases.items():
        with pytest.raises(Infeasible) as err:
            plan_joint("jerk_limited", motion, limits)
        assert str(err.value), what
    with pytest.raises(Infeasible) as err:
        plan_joint("jerk_limited", cases["start velocity over the limit"], limits)
    assert err.value.field == ("start", "velocities", 0) and "j1" in str(err.value)
    with pytest.raises(Infeasible, match="joint j1"):
        plan_joint("jerk_limited", cases["goal state that must overshoot"], limits)


def test_missing_limits_name_the_field() -> None:
    motion = PointToPoint.create([0.0], [1.0])
    for limits, field in (
        (JointLimits(np.ones(1), np.ones(1)), ("limits", "jerk")),
        (JointLimits(acceleration=np.ones(1), jerk=np.ones(1)), ("limits", "velocity")),
        (JointLimits(np.ones(1), np.ones(1), jerk=np.array([0.0])), ("limits", "jerk")),
        (JointLimits(np.ones(1), np.ones(1), jerk=np.ones(2)), ("limits", "jerk")),
    ):
        with pytest.raises(InputError) as err:
            plan_joint("jerk_limited", motion, limits)
        assert err.value.field == field


def test_no_motion_and_ruckig_duration_cap() -> None:
    limits = JointLimits(np.ones(2), np.ones(2), jerk=np.ones(2))
    plan = plan_joint("jerk_limited", PointToPoint.create([0.3, 0.3], [0.3, 0.3]), limits)
    assert plan.trajectory.duration == pytest.approx(1e-3)
    np.testing.assert_array_equal(plan.trajectory.positions, 0.3)
    slow = JointLimits(np.full(1, 1e-3), np.ones(1), jerk=np.ones(1))
    with pytest.raises(Infeasible, match="7600"):
        plan_joint("jerk_limited", PointToPoint.create([0.0], [1e4]), slow)


@pytest.mark.parametrize(
    ("distance", "start_velocity"), [(1e-4, 0.0), (1e-5, 0.0), (1e-4, 1.0), (3e-4, 0.5)]
)
def test_moves_shorter_than_a_millisecond_keep_ruckigs_exact_duration(
    distance: float, start_velocity: float
) -> None:
    """Issue 25 item 12: a sub-millisecond move was stretched to 1 ms with no warning."""
    limits = JointLimits(np.ones(1), np.full(1, 1e4), jerk=np.full(1, 1e8))
    motion = PointToPoint.create([0.0], [distance], [start_velocity], [start_velocity])
    expected = ruckig_direct(motion, limits).duration
    assert 0.0 < expected < 1e-3
    plan = plan_joint("jerk_limited", motion, limits)
    assert plan.profile.duration == pytest.approx(expected, rel=1e-12)
    assert plan.trajectory.times[-1] == pytest.approx(expected, rel=1e-12)
    np.testing.assert_allclose(plan.trajectory.positions[-1], [distance], rtol=0, atol=1e-15)
    if start_velocity:
        return
    # a given duration under 1 ms is kept too (rest to rest: any longer one is feasible)
    given = plan_joint("jerk_limited", motion, limits, duration=1.5 * expected)
    assert given.trajectory.times[-1] == pytest.approx(1.5 * expected, rel=1e-12)


def test_peaks_of_a_known_profile() -> None:
    # Rest to rest, 1 joint, long move: jerk 10 for 0.2 s reaches a = 2, cruise at v = 1.
    limits = JointLimits(np.ones(1), np.full(1, 2.0), jerk=np.full(1, 10.0))
    plan = plan_joint("jerk_limited", PointToPoint.create([0.0], [5.0]), limits, samples=2)
    assert isinstance(plan.profile, JerkLimitedProfile)
    np.testing.assert_allclose(plan.trajectory.peak_velocity, [1.0], rtol=1e-12)
    np.testing.assert_allclose(plan.trajectory.peak_acceleration, [2.0], rtol=1e-12)
    np.testing.assert_allclose(plan.trajectory.peak_jerk, [10.0], rtol=1e-12)
    # Closed form: T = dq/v + v/a + a/j = 5 + 0.5 + 0.2.
    assert plan.trajectory.duration == pytest.approx(5.7, rel=1e-12)


def test_extreme_magnitudes_give_a_plan_or_infeasible_never_another_error() -> None:
    """Limits from 1e-6 to 1e8, states up to 1.5x the limits, durations 1e-3 to 1e5 s: Ruckig's
    exceptions and unnamed result codes (-101, ...) all become ``Infeasible``; plans are finite."""
    rng = np.random.default_rng(RNG_SEED + 99)
    outcomes = {"ok": 0, "infeasible": 0}
    for _ in range(1500):
        dof = int(rng.integers(1, 8))
        limits = JointLimits(
            10 ** rng.uniform(-6, 4, dof),
            10 ** rng.uniform(-6, 6, dof),
            jerk=10 ** rng.uniform(-6, 8, dof),
        )
        scale = 10 ** rng.uniform(-8, 0)
        rates = [rng.uniform(-1, 1, dof) * lim * rng.choice([0.0, 0.5, 1.0, 1.5])
                 for lim in (limits.velocity, limits.velocity, limits.acceleration,
                             limits.acceleration)]  # fmt: skip
        motion = PointToPoint.create(
            rng.uniform(-1e4, 1e4, dof) * scale, rng.uniform(-1e4, 1e4, dof) * scale, *rates
        )
        duration = None if rng.random() < 0.5 else float(10 ** rng.uniform(-3, 5))
        try:
            plan = plan_joint("jerk_limited", motion, limits, duration=duration, samples=20)
        except PlanningError as e:
            assert isinstance(e, (Infeasible, InputError)), (type(e), e, motion, limits)
            assert "inp." not in str(e)  # no dump of Ruckig's input
            outcomes["infeasible"] += 1
            continue
        traj = plan.trajectory
        for values in (traj.positions, traj.velocities, traj.accelerations, *traj.peaks):
            assert np.all(np.isfinite(values)), (motion, limits, duration)
        outcomes["ok"] += 1
    assert outcomes["ok"] >= 50, outcomes
