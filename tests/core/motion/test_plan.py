"""``plan_motion`` / ``find_path`` on a point robot among discs (``discs.Discs``, closed-form
distances): the answer is clear at every instant between its returned points (dense sweep), goes
around what blocks the straight segment, reaches the goal, keeps the limits, is deterministic per
seed, and the failures are the documented ones."""

from __future__ import annotations

import numpy as np
import pytest

from core.budget import Deadline
from core.errors import Collision, InputError, NoPathFound, TimeBudgetExceeded, Unreachable
from core.limits import JointLimits
from core.motion.certify import CERTIFY_MARGIN
from core.motion.goals import Goals, clear_goals
from core.motion.plan import MotionTask, find_path, plan_motion
from tests.core.motion.discs import Discs, min_margin_dense

LIMITS = JointLimits(
    velocity=np.array([1.0, 0.8]),
    acceleration=np.array([2.0, 3.0]),
    position=np.array([[-3.0, 3.0], [-3.0, 3.0]]),
    jerk=np.array([20.0, 20.0]),
)
BLOCK = Discs([[0.0, 0.0], [0.0, 1.6]], [0.8, 0.5], clearance=0.05)
START, GOAL = np.array([-2.0, 0.1]), np.array([2.0, -0.1])


def task(goal=GOAL, **kw) -> MotionTask:
    return MotionTask(START, Goals(np.atleast_2d(goal), (None,), False), LIMITS, **kw)


@pytest.mark.parametrize("timing", ["time_optimal", "jerk_limited"])
def test_goes_around_and_is_clear_between_returned_points(timing: str) -> None:
    result = plan_motion(task(timing=timing), BLOCK)
    traj = result.trajectory
    assert result.planner.name == "rrt_connect"
    np.testing.assert_allclose(traj.positions[[0, -1]], [START, GOAL], atol=1e-12)
    assert min_margin_dense(BLOCK, traj.positions, per_segment=50) >= CERTIFY_MARGIN - 1e-12
    assert np.all(np.abs(traj.velocities) <= LIMITS.velocity * (1 + 1e-9))
    assert np.all(np.abs(traj.accelerations) <= LIMITS.acceleration * (1 + 1e-9))
    np.testing.assert_allclose(traj.velocities[[0, -1]], 0.0, atol=1e-12)
    assert result.path_length >= np.linalg.norm(GOAL - START)
    assert result.path_length_ratio == pytest.approx(
        result.path_length / np.linalg.norm(GOAL - START)
    )
    assert np.all(np.diff(traj.times) > 0)


def test_direct_segment_when_it_is_clear() -> None:
    result = plan_motion(task(goal=np.array([-2.0, -2.0])), BLOCK)
    assert result.planner.name == "direct" and len(result.waypoints) == 2
    assert result.path_length_ratio == pytest.approx(1.0)


def test_same_seed_same_answer_other_seed_other_answer() -> None:
    a = plan_motion(task(seed=3), BLOCK)
    b = plan_motion(task(seed=3), BLOCK)
    c = plan_motion(task(seed=4), BLOCK)
    np.testing.assert_array_equal(a.trajectory.positions, b.trajectory.positions)
    np.testing.assert_array_equal(a.waypoints, b.waypoints)
    assert a.waypoints.shape != c.waypoints.shape or not np.array_equal(a.waypoints, c.waypoints)


def test_start_or_goal_in_collision_before_any_search() -> None:
    with pytest.raises(Collision) as err:
        plan_motion(task(goal=np.array([0.1, 0.0])), BLOCK)
    assert err.value.extra["at"] == "goal" and err.value.extra["links"] == ["point", "disc0"]
    inside = MotionTask(np.array([0.0, 0.3]), Goals(GOAL[None], (None,), False), LIMITS)
    with pytest.raises(Collision) as err:
        plan_motion(inside, BLOCK)
    assert err.value.extra["at"] == "start"


def test_no_path_when_the_goal_is_walled_in() -> None:
    ring = [[2.0 + 0.9 * np.cos(a), 0.9 * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 40)]
    walled = Discs(ring, [0.15] * len(ring))
    with pytest.raises(NoPathFound) as err:
        plan_motion(task(goal=np.array([2.0, 0.0]), max_planning_time=0.3), walled)
    assert err.value.extra["planner"]["name"] == "rrt_connect"
    assert err.value.extra["planner"]["iterations"] > 0


def test_every_goal_candidate_in_collision_is_unreachable() -> None:
    goals = Goals(np.array([[0.0, 0.0], [0.0, 1.6]]), ("a", "b"), True)
    with pytest.raises(Unreachable) as err:
        clear_goals(BLOCK, goals, np.array([False, False]))
    rows = err.value.extra["solutions"]
    assert [r["configuration"] for r in rows] == ["a", "b"]
    assert [r["links"][1] for r in rows] == ["disc0", "disc1"]


def test_pose_goals_reach_the_first_clear_candidate() -> None:
    goals = Goals(np.array([[0.0, 0.0], [2.0, -0.1], [-2.0, -2.0]]), ("in", "far", "near"), True)
    result = plan_motion(MotionTask(START, goals, LIMITS), BLOCK)
    assert result.configuration == "near"  # the clear candidates in order: the direct one first


def test_jerk_limited_needs_jerk_and_the_deadline_holds() -> None:
    no_jerk = JointLimits(LIMITS.velocity, LIMITS.acceleration, LIMITS.position, None)
    with pytest.raises(InputError):
        plan_motion(
            MotionTask(START, Goals(GOAL[None], (None,), False), no_jerk, timing="jerk_limited"),
            BLOCK,
        )
    with pytest.raises((TimeBudgetExceeded, NoPathFound)):
        plan_motion(task(deadline=Deadline(0.0)), BLOCK)


def test_find_path_is_certified_from_start_to_goal() -> None:
    found = find_path(BLOCK, START, GOAL[None], LIMITS.position[:, 0], LIMITS.position[:, 1])
    assert min_margin_dense(BLOCK, found.knots) >= CERTIFY_MARGIN - 1e-12
    assert min_margin_dense(BLOCK, found.shortened) >= CERTIFY_MARGIN - 1e-12
    s = np.linspace(0.0, found.path.length, 20001)
    d = np.linalg.norm(found.path(s)[:, None] - BLOCK.centers[None], axis=2) - BLOCK.radii
    assert (d - BLOCK.threshold).min() >= CERTIFY_MARGIN - 1e-9
    assert found.planner.simplify_time_ms >= 0 and found.planner.states > 0


@pytest.mark.parametrize("timing", ["time_optimal", "jerk_limited"])
def test_returned_derivatives_are_exact(timing: str) -> None:
    """Integrating the returned accelerations between consecutive points (trapezoid rule) gives
    the returned velocities to 1e-6 (sampled finely, as the retime test does: on a blend the
    acceleration is not linear between points); every switch of the timing is held by the points
    (a jump of the acceleration between two points is integrated wrongly by up to ~1e-3)."""
    traj = plan_motion(task(timing=timing, sample_period=0.001), BLOCK).trajectory
    t, q, v, a = traj.times, traj.positions, traj.velocities, traj.accelerations
    dt = np.diff(t)[:, None]
    np.testing.assert_allclose(np.diff(v, axis=0), dt * (a[1:] + a[:-1]) / 2, atol=1e-6)
    # and the velocities are those of the positions (central differences around each point)
    inner = (dt[:-1, 0] > 1e-4) & (dt[1:, 0] > 1e-4)
    fd = (q[2:] - q[:-2]) / (t[2:] - t[:-2])[:, None]
    np.testing.assert_allclose(fd[inner], v[1:-1][inner], atol=5e-3)
