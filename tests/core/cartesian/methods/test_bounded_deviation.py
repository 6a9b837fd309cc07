"""Taylor's bounded deviation (``core.cartesian.methods.bounded_deviation``).

The deviation promise is checked here independently of the planner's own measurement: between every
two consecutive returned points, joints interpolated linearly and by cubic Hermite at 12 points, FK by
the robot, the distance of the tool to the line segment, and the angle to the slerp at the closest
point (``independent_deviation``). Also: joint limits, velocity limits, rest at the end, the last
point on the goal pose, knots on the start's IK branch, the regression cases where the midpoint test
passes but the segment strays elsewhere, and every failure code.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.budget import Deadline
from core.cartesian.knot_path import KnotPath, Knots
from core.cartesian.measure import measure_deviation
from core.cartesian.methods.bounded_deviation import taylor_knots
from core.cartesian.plan import plan
from core.cartesian.task import CartesianTask
from core.errors import (
    BranchFlip,
    Infeasible,
    InputError,
    JointLimit,
    JointRateLimit,
    TimeBudgetExceeded,
    Unreachable,
)
from core.path.line import StraightLine
from core.trajectory import Trajectory
from tests.core.conftest import (
    SHIPPED_MOVES,
    FlippingArm,
    assert_valid,
    gantry_task,
    independent_deviation,
    offset_move,
    registry_robot,
    shipped_task,
    ur5_task,
    xy,
)
from tests.toy_kinematics import ToyPlanar2R

# --- the promise on the shipped robots ---------------------------------------------------------


def test_ur5_move_within_tolerance_everywhere_with_knots_on_the_line():
    task = ur5_task()
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)
    line = task.line()
    # Taylor's knots lie on the line at their own s (IK there).
    T = task.robot.fk_many(result.knots["positions"])
    expected = line.poses(result.knots["s"])
    assert np.abs(T[:, :3, 3] - expected[:, :3, 3]).max() <= 1e-6
    diag = result.diagnostics
    assert diag["knot_count"] > 2 and diag["midpoint_tests"] >= diag["knot_count"] - 1
    assert diag["max_recursion_depth"] >= 1


@pytest.mark.parametrize("name", sorted(SHIPPED_MOVES))
def test_shipped_robots_within_tolerance(name):
    task = shipped_task(name)
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)


def test_tight_tolerance_needs_more_knots_and_holds():
    loose = plan(shipped_task("planar_2r"), "bounded_deviation")
    task = shipped_task("planar_2r", position_tolerance=1e-4)
    tight = plan(task, "bounded_deviation")
    assert_valid(task, tight)
    assert tight.diagnostics["knot_count"] > loose.diagnostics["knot_count"]


def test_fixed_duration_and_samples_are_honored():
    task = shipped_task("ur5", duration=4.0)
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)
    assert result.trajectory.duration == pytest.approx(4.0)
    task = shipped_task("ur5", samples=400)
    result = plan(task, "bounded_deviation")
    assert len(result.trajectory.times) == 400
    assert_valid(task, result)


@pytest.mark.parametrize("method", ["bounded_deviation", "bounded_deviation_nlp"])
@pytest.mark.parametrize(("dp", "angle"), [((0.0, 0.0, 0.0), 0.6), ((0.2, 0.1, 0.0), 0.0)])
def test_pure_rotation_and_pure_translation(method, dp, angle):
    robot = registry_robot("ur5")
    T_goal = offset_move(robot, robot.home, np.array(dp), (0.3, 1.0, 0.2), angle)
    task = CartesianTask(robot, robot.home.copy(), T_goal)
    assert_valid(task, plan(task, method))


def test_goal_positions_on_the_branch_are_the_last_point():
    robot = registry_robot("ur5")
    q_goal = robot.home + np.array([0.3, -0.2, 0.25, -0.1, 0.2, 0.3])
    task = CartesianTask(robot, robot.home.copy(), robot.fk(q_goal), q_goal=q_goal)
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)
    np.testing.assert_array_equal(result.trajectory.positions[-1], q_goal)
    assert result.warnings == ()


def test_goal_positions_on_another_branch_end_on_the_start_branch_with_a_warning():
    arm = ToyPlanar2R()
    q0, q_goal = np.array([0.3, 1.2]), np.array([1.1, 0.6])
    # The same goal point with the elbow bent the other way.
    T_goal = arm.fk(q_goal)
    other = arm.ik(T_goal, np.array([1.1 + 0.6, -0.6])).positions
    assert other[1] < 0
    task = CartesianTask(arm, q0, T_goal, q_goal=other)
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)
    assert result.trajectory.positions[-1][1] > 0  # stayed elbow-up, no flip
    assert any("another joint configuration" in w for w in result.warnings)


# --- the midpoint is only a heuristic: regressions ---------------------------------------------


def test_midpoint_passes_but_segment_strays_is_caught_by_dense_measurement():
    task = gantry_task(periods=1.0, amplitude=0.004)
    g, line = task.robot, task.line()
    # The classic midpoint test alone is satisfied by the straight joint segment...
    knots = taylor_knots(g, line, task.q_start, task.q_goal, 1e-3, 1e-2)
    assert len(knots) == 2
    # ... which strays by 4 mm at a quarter of the way (dense measurement sees it).
    times = np.array([0.0, 1.0])
    naive = Trajectory(times, knots.positions, np.zeros((2, 2)), np.zeros((2, 2)))
    assert measure_deviation(g, line, naive).max_position > 3e-3
    assert independent_deviation(g, line, naive)[0] > 3e-3
    # The planner splits the segment and returns a trajectory within the tolerance.
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)
    assert result.diagnostics["midpoint_knot_count"] == 2
    assert result.diagnostics["path_splits"] >= 1 and result.diagnostics["knot_count"] > 2


def test_returned_trajectory_measurement_catches_what_the_knot_path_checks_miss():
    # 17 periods: the tip is on the line at every check of the knot path's own check (k/17) and at
    # the midpoint; only the dense measurement of the returned trajectory sees the 2 mm strays.
    task = gantry_task(periods=17.0, amplitude=0.002)
    result = plan(task, "bounded_deviation")
    assert_valid(task, result)
    assert result.diagnostics["midpoint_knot_count"] == 2
    assert result.diagnostics["path_splits"] == 0
    assert result.diagnostics["resplits"] >= 1


# --- failures: every code, with its location -------------------------------------------------


def test_unreachable_line_through_the_hole_and_partial_prefix():
    arm = ToyPlanar2R()  # reach 0.2 m to 1.8 m: a line past the base crosses the hole
    q0 = arm.ik(xy(0.5, 0.05), np.array([0.0, 1.0])).positions
    task = CartesianTask(arm, q0, xy(-0.5, 0.05))
    with pytest.raises(Unreachable) as err:
        plan(task, "bounded_deviation")
    assert 0.2 < err.value.s < 0.45
    partial = plan(CartesianTask(arm, q0, xy(-0.5, 0.05), allow_partial=True), "bounded_deviation")
    assert 0.2 < partial.fraction < err.value.s
    assert isinstance(partial.failure, Unreachable)
    assert partial.knots["s"][-1] == pytest.approx(partial.fraction)
    prefix = CartesianTask(arm, q0, task.line().pose(partial.fraction))
    pos, _ = independent_deviation(arm, prefix.line(), partial.trajectory)
    assert pos <= 1e-3


def test_joint_limit_on_the_line():
    arm = ToyPlanar2R()
    arm.position_limits = np.array([[-0.1, np.pi], [-np.pi, np.pi]])
    # Both ends have q1 = 0; on the line between them q1 dips to -0.22 rad.
    task = CartesianTask(arm, np.array([0.0, 0.5]), arm.fk(np.array([0.0, 2.0])))
    with pytest.raises(JointLimit) as err:
        plan(task, "bounded_deviation")
    assert 0.0 < err.value.s < 1.0


def test_start_outside_the_limits_names_the_field():
    arm = ToyPlanar2R()
    with pytest.raises(JointLimit) as err:
        plan(CartesianTask(arm, np.array([4.0, 0.5]), xy(1.0, 0.5)), "bounded_deviation")
    assert err.value.field == ("start", "positions", 0)


def test_branch_flip_is_rejected_with_its_s():
    arm = FlippingArm()
    q0, q1 = np.array([0.3, 1.2]), np.array([1.1, 0.6])
    line = StraightLine(arm.fk(q0), arm.fk(q1), arm.task_space)
    with pytest.raises(BranchFlip) as err:
        taylor_knots(arm, line, q0, q1, 1e-3, 1e-2)
    assert err.value.s == 0.5
    with pytest.raises(BranchFlip) as err:
        plan(CartesianTask(arm, q0, arm.fk(q1)), "bounded_deviation")
    assert err.value.s is not None and 0.0 < err.value.s < 1.0


def test_depth_limit_is_infeasible_with_its_s():
    arm = ToyPlanar2R()
    q0, q1 = np.array([0.3, 1.2]), np.array([1.1, 0.6])
    line = StraightLine(arm.fk(q0), arm.fk(q1), arm.task_space)
    with pytest.raises(Infeasible) as err:
        taylor_knots(arm, line, q0, q1, 1e-3, 1e-2, max_depth=1)
    assert err.value.s is not None and err.value.extra["depth"] == 1


def test_returned_points_too_far_apart_are_infeasible():
    arm = ToyPlanar2R()
    task = CartesianTask(arm, np.array([0.3, 1.2]), arm.fk(np.array([1.1, 0.6])), samples=3)
    with pytest.raises(Infeasible) as err:
        plan(task, "bounded_deviation")
    assert "too far apart" in err.value.detail and err.value.s is not None


def test_duration_too_short_is_a_joint_rate_limit():
    arm = ToyPlanar2R()
    task = CartesianTask(arm, np.array([0.3, 1.2]), arm.fk(np.array([1.1, 0.6])), duration=0.05)
    with pytest.raises(JointRateLimit) as err:
        plan(task, "bounded_deviation")
    assert err.value.extra["min_duration"] > 0.05


def test_time_budget_exceeded():
    arm = ToyPlanar2R()
    task = CartesianTask(arm, np.array([0.3, 1.2]), xy(0.9, 0.5), deadline=Deadline(0.0))
    with pytest.raises(TimeBudgetExceeded):
        plan(task, "bounded_deviation")


@pytest.mark.parametrize(
    ("extra", "field"),
    [
        ({"position_tolerance": 0.0}, ("tolerance", "position")),
        ({"orientation_tolerance": float("nan")}, ("tolerance", "orientation")),
    ],
)
def test_invalid_tolerance_is_a_validation_error(extra, field):
    arm = ToyPlanar2R()
    with pytest.raises(InputError) as err:
        plan(CartesianTask(arm, np.array([0.3, 1.2]), xy(0.9, 0.5), **extra), "bounded_deviation")
    assert err.value.field == field


def test_zero_length_line_is_a_validation_error():
    arm = ToyPlanar2R()
    q0 = np.array([0.3, 1.2])
    with pytest.raises(InputError):
        plan(CartesianTask(arm, q0, arm.fk(q0)), "bounded_deviation")


# --- building blocks ---------------------------------------------------------------------------


def test_knot_path_interpolates_the_knots_and_is_c2():
    s = np.array([0.0, 0.2, 0.5, 0.55, 1.0])
    q = np.random.default_rng(3).normal(size=(5, 3))
    path = KnotPath(Knots(s, q))
    np.testing.assert_allclose(path(s), q, atol=1e-14)
    for order in (0, 1, 2):
        left, right = path(s[1:-1] - 1e-9, order), path(s[1:-1] + 1e-9, order)
        np.testing.assert_allclose(left, right, atol=1e-5)
    two = KnotPath(Knots(np.array([0.0, 1.0]), q[:2]))
    np.testing.assert_allclose(two(np.array([0.25])), [0.75 * q[0] + 0.25 * q[1]], atol=1e-14)


# --- examples and sweeps -------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(12))
def test_random_ur5_moves(seed):
    rng = np.random.default_rng(seed)
    robot = registry_robot("ur5")
    q0 = robot.home + rng.uniform(-0.3, 0.3, size=6)
    dp = rng.normal(size=3)
    dp *= rng.uniform(0.05, 0.3) / np.linalg.norm(dp)
    T_goal = offset_move(robot, q0, dp, rng.normal(size=3), rng.uniform(0.0, 0.6))
    tol = (10 ** rng.uniform(-4, -2.5), 10 ** rng.uniform(-3, -1.5))
    task = CartesianTask(robot, q0, T_goal, position_tolerance=tol[0], orientation_tolerance=tol[1])
    try:
        result = plan(task, "bounded_deviation")
    except (Unreachable, JointLimit, BranchFlip) as err:
        pytest.skip(f"seed {seed}: {err.code} at s={err.s}")
    print(f"seed {seed}: q0={q0.tolist()} dp={dp.tolist()} tol={tol}")
    assert_valid(task, result)
