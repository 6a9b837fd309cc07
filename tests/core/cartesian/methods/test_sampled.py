"""Sampled IK along the line, on the toy arm and the shipped robots.

Every check is made here from the robot's forward kinematics (``fk_many``) against an independent
line (position: distance to the segment; orientation: scipy's Slerp at the closest point), never
read from the planner's diagnostics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from core.budget import Deadline
from core.cartesian import walk as walk_module
from core.cartesian.methods.sampled import plan_sampled
from core.cartesian.path_rates import path_rates
from core.cartesian.plan import plan
from core.cartesian.task import CartesianTask
from core.cartesian.walk import check_grid, walk_line
from core.errors import (
    BranchFlip,
    Infeasible,
    InputError,
    JointLimit,
    JointRateLimit,
    Singularity,
    TimeBudgetExceeded,
    TooLarge,
    Unreachable,
)
from core.kinematics import SINGULAR_VALUE_THRESHOLD
from core.path.line import StraightLine
from robots import registry
from tests.core.conftest import toy_task
from tests.toy_kinematics import FlippingToy, ToyPlanar2R

PUMA_Q2, PUMA_Q3 = math.pi / 4, -math.pi
UR5_HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])


def line_errors(robot, T0, T1, positions):
    """Distance [m] and angle [rad] of the tool at each row of ``positions`` from the line."""
    xy = robot.task_space == "position_xy"
    rows = slice(0, 2) if xy else slice(0, 3)
    T = robot.fk_many(np.asarray(positions))
    p0, d = T0[rows, 3], T1[rows, 3] - T0[rows, 3]
    R0 = Rotation.from_matrix(T0[:3, :3])
    if d @ d > 1e-12:
        s = np.clip((T[:, rows, 3] - p0) @ d / (d @ d), 0.0, 1.0)
    else:  # a pure rotation: s from the angle turned
        axis = (R0.inv() * Rotation.from_matrix(T1[:3, :3])).as_rotvec()
        rel = (R0.inv() * Rotation.from_matrix(T[:, :3, :3])).as_rotvec()
        s = np.clip(rel @ axis / (axis @ axis), 0.0, 1.0)
    position = np.linalg.norm(T[:, rows, 3] - (p0 + s[:, None] * d), axis=1)
    if xy:
        return position, np.zeros(len(s)), s
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]])))
    return position, (slerp(s).inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude(), s


def assert_valid(task, result, end_on_goal=True):
    """Points on the line, the end on the goal, limits held, no jump between points."""
    robot, traj = task.robot, result.trajectory
    T0, T1 = robot.fk(task.q_start), task.line().T_goal
    position, orientation, _ = line_errors(robot, T0, T1, traj.positions)
    assert position.max() <= 1e-6 and orientation.max() <= 1e-6
    if end_on_goal:
        T_end = robot.fk(traj.positions[-1])
        rows = slice(0, 2) if robot.task_space == "position_xy" else slice(0, 3)
        assert np.linalg.norm(T_end[rows, 3] - T1[rows, 3]) <= 1e-6
        if robot.task_space == "pose":
            assert Rotation.from_matrix(T_end[:3, :3].T @ T1[:3, :3]).magnitude() <= 1e-6
    assert np.all(np.diff(traj.times) > 0) and traj.times[0] == 0.0
    assert np.all(traj.velocities[[0, -1]] == 0.0)
    lo, hi = robot.position_limits.T
    assert np.all(traj.positions >= lo - 1e-9) and np.all(traj.positions <= hi + 1e-9)
    assert np.all(np.abs(traj.velocities) <= robot.velocity_limits * (1 + 1e-9))
    # No branch flip: between two points no joint moves farther than its speed limit allows.
    step = np.abs(np.diff(traj.positions, axis=0)) / np.diff(traj.times)[:, None]
    assert np.all(step <= robot.velocity_limits * 1.05)


def dense_linear_deviation(task, traj, checks=10):
    """Largest position deviation [m] of joint-linear interpolation between the points."""
    frac = np.arange(1, checks + 1) / (checks + 1)
    q = traj.positions[:-1, None] + frac[None, :, None] * np.diff(traj.positions, axis=0)[:, None]
    T0, T1 = task.robot.fk(task.q_start), task.line().T_goal
    return line_errors(task.robot, T0, T1, q.reshape(-1, task.robot.dof))[0].max()


def pose(p, rotvec, T_ref=None):
    T = np.eye(4)
    R = Rotation.from_rotvec(rotvec).as_matrix()
    T[:3, :3] = R if T_ref is None else R @ T_ref[:3, :3]
    T[:3, 3] = p
    return T


# --- the shipped robots, lines with rotation -----------------------------------------------------


@pytest.mark.parametrize(
    ("name", "dp", "rotvec"),
    [
        ("ur5", [0.1, 0.2, -0.1], [0.3, 0.2, 0.5]),
        ("ur5", [-0.05, 0.1, 0.15], [0.0, -0.6, 0.2]),
        ("panda", [0.1, -0.2, -0.15], [0.4, -0.3, 0.2]),
        ("panda", [0.2, 0.15, -0.2], [0.0, 0.0, 0.8]),
    ],
)
def test_lines_with_rotation_on_shipped_arms(name, dp, rotvec):
    robot = registry.get(name)
    T0 = robot.fk(robot.home)
    T_goal = pose(T0[:3, 3] + dp, rotvec, T0)
    task = CartesianTask(robot=robot, q_start=robot.home, T_goal=T_goal)
    result = plan(task, "sampled")
    assert result.fraction == 1.0 and result.failure is None
    assert_valid(task, result)
    assert task.line().angle > 0.3
    # The reported dense deviation covers at least what joint-linear interpolation does.
    own = dense_linear_deviation(task, result.trajectory)
    assert result.deviation.max_position >= own - 1e-12
    assert result.min_singular_value >= SINGULAR_VALUE_THRESHOLD


def test_goal_positions_end_exactly_there():
    robot = registry.get("ur5")
    q_goal = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
    task = CartesianTask(robot=robot, q_start=UR5_HOME, T_goal=robot.fk(q_goal), q_goal=q_goal)
    result = plan(task, "sampled")
    assert np.array_equal(result.trajectory.positions[-1], q_goal)
    assert not result.warnings
    assert_valid(task, result)


def test_samples_are_equally_spaced_in_s():
    robot = registry.get("ur5")
    q_goal = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
    task = CartesianTask(robot=robot, q_start=UR5_HOME, T_goal=robot.fk(q_goal), samples=7)
    result = plan(task, "sampled")
    assert len(result.trajectory.times) == 7
    line = task.line()
    _, _, s = line_errors(robot, line.T_start, line.T_goal, result.trajectory.positions)
    assert np.allclose(s, np.linspace(0, 1, 7), atol=1e-6)
    assert_valid(task, result)


def test_half_turn_of_the_tool_is_measured_on_the_line():
    """A goal turned by exactly pi (the two arcs are equally short): deviation stays small."""
    robot = registry.get("ur5")
    T0 = robot.fk(UR5_HOME)
    T_goal = np.eye(4)
    T_goal[:3, 3] = [-0.55, 0.0, 0.25]
    task = CartesianTask(robot=robot, q_start=UR5_HOME, T_goal=T_goal)
    assert abs(task.line().angle - math.pi) < 1e-9  # the start orientation is a half turn
    assert np.allclose(T0[:3, :3] @ T0[:3, :3], np.eye(3))
    result = plan(task, "sampled")
    assert_valid(task, result)
    assert result.deviation.max_position < 1e-4 and result.deviation.max_orientation < 1e-3


# --- Type I: the planar arm's hole and outer rim --------------------------------------------------


def planar_task(start_xy, goal_xy, **kw):
    robot = registry.get("planar_2r")
    x, y = start_xy
    c2 = (x * x + y * y - 1.64) / 1.6
    q2 = math.acos(c2)
    q1 = math.atan2(y, x) - math.atan2(0.8 * math.sin(q2), 1.0 + 0.8 * math.cos(q2))
    T_goal = np.eye(4)
    T_goal[:2, 3] = goal_xy
    return CartesianTask(robot=robot, q_start=np.array([q1, q2]), T_goal=T_goal, **kw)


def circle_entry(p0, p1, r):
    """Smallest s in [0, 1] where |p0 + s (p1 - p0)| = r."""
    p0, d = np.asarray(p0), np.asarray(p1) - np.asarray(p0)
    a, b, c = d @ d, 2 * p0 @ d, p0 @ p0 - r * r
    roots = np.roots([a, b, c]).real
    return float(min(x for x in roots if 0 <= x <= 1))


@pytest.mark.parametrize(
    ("start", "goal", "radius"),
    [
        ((-0.8, 0.05), (0.8, 0.05), 0.2),  # through the hole r < 0.2 m
        ((0.5, -0.5), (-0.3, 0.6), 0.2),
        ((1.0, 0.5), (2.5, 0.5), 1.8),  # leaving r > 1.8 m
    ],
)
def test_planar_unreachable_at_the_right_s(start, goal, radius):
    if radius == 0.2:
        s_true = circle_entry(start, goal, radius)
    else:
        s_true = (math.sqrt(1.8**2 - start[1] ** 2) - start[0]) / (goal[0] - start[0])
    with pytest.raises(Unreachable) as err:
        plan(planar_task(start, goal), "sampled")
    assert abs(err.value.s - s_true) <= 0.02
    assert abs(err.value.s - s_true) <= 1e-3  # in fact much closer
    task = planar_task(start, goal, allow_partial=True)
    result = plan(task, "sampled")
    assert abs(result.fraction - s_true) <= 0.02
    assert result.fraction <= err.value.s
    assert isinstance(result.failure, Unreachable)
    assert "planned" in result.warnings[0]
    assert_valid(task, result, end_on_goal=False)
    # The prefix ends on the line at s = fraction.
    end = task.robot.fk(result.trajectory.positions[-1])[:2, 3]
    line = task.line()
    assert np.linalg.norm(end - line.positions(np.array([result.fraction]))[0, :2]) <= 1e-6


# --- Type II: the PUMA's wrist ---------------------------------------------------------------------


def test_puma_line_through_the_wrist_singularity_is_reported():
    robot = registry.get("puma560")
    qa = np.array([0.0, PUMA_Q2, PUMA_Q3, 0.0, 0.3, 0.0])
    qb = np.array([0.0, PUMA_Q2, PUMA_Q3, 0.0, -0.3, 0.0])
    task = CartesianTask(robot=robot, q_start=qa, T_goal=robot.fk(qb))
    with pytest.raises(Singularity) as err:
        plan(task, "sampled")
    assert 0.4 < err.value.s < 0.6
    partial = plan(
        CartesianTask(robot=robot, q_start=qa, T_goal=robot.fk(qb), allow_partial=True), "sampled"
    )
    assert (
        partial.fraction <= err.value.s and partial.min_singular_value >= SINGULAR_VALUE_THRESHOLD
    )
    assert_valid(task, partial, end_on_goal=False)


@pytest.mark.parametrize("q5", [0.05, 0.2])
def test_puma_line_near_the_wrist_singularity_is_slowed_within_limits(q5):
    robot = registry.get("puma560")
    qa = np.array([0.0, PUMA_Q2, PUMA_Q3, 0.4, q5, -0.4])
    qb = np.array([0.05, PUMA_Q2, PUMA_Q3, -0.4, -q5, 0.4])
    task = CartesianTask(robot=robot, q_start=qa, T_goal=robot.fk(qb), q_goal=qb)
    result = plan(task, "sampled")
    assert result.fraction == 1.0
    assert_valid(task, result)
    assert any("velocity limits slow the tool" in w for w in result.warnings)
    assert result.diagnostics["slowdown"] < 0.2
    # The wrist turns by about pi in q4 and q6 near q5 = 0: it is where the rates would blow up.
    traj = result.trajectory
    assert np.ptp(traj.positions[:, 3]) > 2.0
    assert np.abs(traj.positions[:, 4]).min() < q5
    assert np.abs(traj.velocities).max(axis=0)[3] >= 0.99 * robot.velocity_limits[3]
    assert any("another joint configuration" in w for w in result.warnings)


# --- timing: a fixed duration, speed limits ------------------------------------------------------


def ur5_line(**kw):
    robot = registry.get("ur5")
    q_goal = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
    return CartesianTask(
        robot=robot, q_start=UR5_HOME, T_goal=robot.fk(q_goal), q_goal=q_goal, **kw
    )


def test_too_short_duration_is_joint_rate_limit_and_speed_limits_plan_it():
    with pytest.raises(JointRateLimit) as err:
        plan(ur5_line(duration=0.1), "sampled")
    assert 0.0 < err.value.s < 1.0 and err.value.field == ("duration",)
    min_duration = err.value.extra["min_duration"]
    assert 0.1 < min_duration < 1.0
    for task in (
        ur5_line(max_linear_speed=1.0, max_angular_speed=3.0),
        ur5_line(duration=min_duration * 1.001),
    ):
        result = plan(task, "sampled")
        assert_valid(task, result)
    with pytest.raises(JointRateLimit):
        plan(ur5_line(duration=min_duration * 0.98), "sampled")
    # At the shortest duration a joint runs at its velocity or acceleration limit.
    traj = plan(ur5_line(duration=min_duration * 1.001), "sampled").trajectory
    robot = ur5_line().robot
    v_ratio = (traj.peak_velocity / robot.velocity_limits).max()
    a_ratio = (traj.peak_acceleration / robot.acceleration_limits).max()
    assert max(v_ratio, a_ratio) > 0.98


def test_fixed_duration_is_kept():
    task = ur5_line(duration=2.5, sample_period=0.02)
    result = plan(task, "sampled")
    assert result.trajectory.duration == 2.5
    assert len(result.trajectory.times) == 126
    assert_valid(task, result)


def test_speed_limits_hold_for_the_tool():
    task = ur5_line(max_linear_speed=0.05, max_angular_speed=0.1)
    traj = plan(task, "sampled").trajectory
    T = task.robot.fk_many(traj.positions)
    dt = np.diff(traj.times)
    speed = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1) / dt
    turn = Rotation.from_matrix(T[1:, :3, :3]) * Rotation.from_matrix(T[:-1, :3, :3]).inv()
    assert speed.max() <= 0.05 * 1.001
    assert (turn.magnitude() / dt).max() <= 0.1 * 1.001


# --- rates, grid, failures ------------------------------------------------------------------------


def test_path_rates_are_the_derivatives_of_the_ik_path():
    robot = registry.get("ur5")
    T0 = robot.fk(UR5_HOME)
    line = StraightLine(T0, pose(T0[:3, 3] + [0.1, 0.1, 0.0], [0.2, 0.0, 0.3], T0))
    s, h = 0.4, 1e-4

    def solve(at, seed):
        return robot.ik(line.pose(at), seed, position_tolerance=1e-12, orientation_tolerance=1e-12)

    q = UR5_HOME
    for si in np.linspace(0, s, 60)[1:]:
        q = solve(si, q).positions
    q_mid = q
    q_lo, q_hi = solve(s - h, q_mid).positions, solve(s + h, q_mid).positions
    rates = path_rates(robot, line, q_mid[None])
    assert np.allclose(rates.dq_ds[0], (q_hi - q_lo) / (2 * h), atol=1e-6)
    assert np.allclose(rates.d2q_ds2[0], (q_hi - 2 * q_mid + q_lo) / h**2, atol=1e-3)
    J = robot.jacobian(q_mid)
    assert np.allclose(J @ rates.dq_ds[0], line.twist(np.array([1.0]))[0], atol=1e-9)


def test_check_grid_follows_the_tolerance():
    task = ur5_line()
    line = task.line()
    assert len(check_grid(task, line)) == walk_module.MIN_INTERVALS + 1
    fine = ur5_line(position_tolerance=1e-4)
    n = math.ceil(line.length / (walk_module.STEP_PER_TOLERANCE * 1e-4))
    assert len(check_grid(fine, line)) == n + 1
    tiny = ur5_line(position_tolerance=1e-6)
    assert len(check_grid(tiny, line)) == walk_module.MAX_INTERVALS + 1


def test_toy_arm_line_is_on_the_line():
    task = toy_task()
    result = plan_sampled(task)
    assert_valid(task, result)


def test_branch_flip_is_refused_with_its_s():
    robot = FlippingToy()
    task = toy_task(robot)
    line = task.line()
    s_flip = (1.1 - line.p0[0]) / line.delta_p[0]
    assert 0.2 < s_flip < 0.8
    with pytest.raises(BranchFlip) as err:
        plan_sampled(task)
    assert abs(err.value.s - s_flip) < 1e-3
    result = plan_sampled(toy_task(robot, allow_partial=True))
    assert isinstance(result.failure, BranchFlip) and result.fraction <= err.value.s
    assert_valid(task, result, end_on_goal=False)


def test_joint_limits_start_and_along_the_line():
    robot = registry.get("puma560")
    bad = np.array([0.0, PUMA_Q2, PUMA_Q3, 0.0, 3.0, 0.0])
    with pytest.raises(JointLimit) as err:
        plan(CartesianTask(robot=robot, q_start=bad, T_goal=robot.fk(robot.home)), "sampled")
    assert err.value.s == 0.0 and err.value.joint == 4
    # Turning the wrist by pi from q4 = 0.05 needs q4 = 3.19 > 2.97: the only solutions on this
    # branch leave the limits.
    qa = np.array([0.0, PUMA_Q2, PUMA_Q3, 0.05, 0.1, -0.05])
    qb = np.array([0.05, PUMA_Q2, PUMA_Q3, -0.05, -0.1, 0.05])
    with pytest.raises(JointLimit) as err:
        plan(CartesianTask(robot=robot, q_start=qa, T_goal=robot.fk(qb)), "sampled")
    assert 0.5 < err.value.s < 0.9


def test_singular_start_and_other_errors():
    with pytest.raises(Singularity) as err:
        plan(
            CartesianTask(robot=ToyPlanar2R(), q_start=np.array([0.3, 0.0]), T_goal=np.eye(4)),
            "sampled",
        )
    assert err.value.s == 0.0
    with pytest.raises(InputError):
        robot = registry.get("ur5")
        plan(CartesianTask(robot=robot, q_start=UR5_HOME, T_goal=robot.fk(UR5_HOME)), "sampled")
    with pytest.raises(InputError):
        plan(
            CartesianTask(robot=registry.get("ur5"), q_start=np.zeros(5), T_goal=np.eye(4)),
            "sampled",
        )
    with pytest.raises(TimeBudgetExceeded):
        plan(ur5_line(deadline=Deadline(0.0)), "sampled")
    with pytest.raises(TooLarge):
        plan(ur5_line(duration=100.0, sample_period=1e-4), "sampled")
    with pytest.raises(Infeasible):
        plan(ur5_line(max_linear_speed=1e-6, max_angular_speed=1e-6), "sampled")


def test_walk_refines_near_trouble():
    task = planar_task((-0.8, 0.05), (0.8, 0.05))
    walk = walk_line(task, task.line())
    assert isinstance(walk.failure, Unreachable)
    assert np.min(np.diff(walk.s)) <= 2 * walk_module.MIN_STEP
    assert np.all(np.diff(walk.s) > 0)


# --- a seeded sweep: every outcome is a valid trajectory or a located failure --------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", ["planar_2r", "puma560", "ur5", "panda"])
def test_random_lines_are_valid_or_located_failures(name):
    from core.errors import PlanningError

    robot = registry.get(name)
    rng = np.random.default_rng(7)
    lo, hi = robot.position_limits.T
    outcomes = {}
    for trial in range(25):
        q0 = np.clip(robot.home + rng.normal(scale=0.4, size=robot.dof), lo, hi)
        T0 = robot.fk(q0)
        T_goal = pose(T0[:3, 3] + rng.normal(scale=0.25, size=3), rng.normal(scale=0.5, size=3), T0)
        for partial in (False, True):
            task = CartesianTask(robot=robot, q_start=q0, T_goal=T_goal, allow_partial=partial)
            try:
                result = plan(task, "sampled")
            except PlanningError as err:
                assert err.s is None or 0.0 <= err.s <= 1.0, (trial, err)
                assert err.code != "validation", (trial, err)
                outcomes[err.code] = outcomes.get(err.code, 0) + 1
                continue
            try:
                assert_valid(task, result, end_on_goal=result.fraction == 1.0)
            except AssertionError:
                print(
                    f"failing input: {name} trial {trial} q0={q0.tolist()} T_goal={T_goal.tolist()}"
                )
                raise
            outcomes["ok" if result.fraction == 1.0 else "partial"] = (
                outcomes.get("ok" if result.fraction == 1.0 else "partial", 0) + 1
            )
    print(name, outcomes)
    assert outcomes.get("ok", 0) > 0
