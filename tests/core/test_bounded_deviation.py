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
from scipy.interpolate import CubicHermiteSpline
from scipy.spatial.transform import Rotation, Slerp

from core.budget import Deadline
from core.cartesian.ik_on_path import continuation, reference_at
from core.cartesian.knot_path import KnotPath, Knots
from core.cartesian.measure import measure_deviation
from core.cartesian.methods.bounded_deviation import taylor_knots
from core.cartesian.plan import plan
from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import (
    BranchFlip,
    Infeasible,
    InputError,
    JointLimit,
    JointRateLimit,
    TimeBudgetExceeded,
    Unreachable,
)
from core.kinematics import DerivedKinematics, IKResult, task_rows
from core.path.line import StraightLine
from core.trajectory import Trajectory
from tests.toy_kinematics import ToyPlanar2R

CHECKS = 12
"""Points checked between two consecutive returned samples (the API promises at least 10)."""


# --- independent checks ----------------------------------------------------------------------


def independent_deviation(kin, line: StraightLine, traj: Trajectory) -> tuple[float, float]:
    """Largest position [m] and orientation [rad] deviation between the returned samples.

    Joints interpolated linearly and by cubic Hermite (what a ROS controller does) at ``CHECKS``
    points of every interval, the samples included; position: distance to the line segment (the
    closest point by position); orientation: angle to the slerp at that closest point.
    """
    t = traj.times
    frac = np.arange(CHECKS + 1) / (CHECKS + 1)
    dense = np.append((t[:-1, None] + frac * np.diff(t)[:, None]).ravel(), t[-1])
    q_lin = np.array([np.interp(dense, t, col) for col in traj.positions.T]).T
    q_herm = CubicHermiteSpline(t, traj.positions, traj.velocities, axis=0)(dense)
    T0, T1 = line.T_start, line.T_goal
    xy = line.task_space == "position_xy"
    rows = slice(0, 2) if xy else slice(0, 3)
    p0, d = T0[rows, 3], T1[rows, 3] - T0[rows, 3]
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]])))
    worst_p, worst_o = 0.0, 0.0
    for q in (q_lin, q_herm):
        T = kin.fk_many(q)
        p = T[:, rows, 3]
        if d @ d > 1e-12:
            s = np.clip((p - p0) @ d / (d @ d), 0.0, 1.0)
        else:  # a pure rotation: the closest slerp orientation, by brute force
            grid = np.linspace(0.0, 1.0, 401)
            R_grid = slerp(grid).as_matrix()
            cos = np.einsum("gij,nij->ng", R_grid, T[:, :3, :3])  # trace(R_grid^T R)
            s = grid[np.argmax(cos, axis=1)]
        worst_p = max(worst_p, float(np.linalg.norm(p - (p0 + s[:, None] * d), axis=1).max()))
        if not xy:
            angle = (slerp(s).inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()
            worst_o = max(worst_o, float(angle.max()))
    return worst_p, worst_o


def assert_valid(task: CartesianTask, result: CartesianResult) -> None:
    """Within tolerance everywhere, limits, rest, end on the goal, knots consistent and on-branch."""
    kin, traj, line = task.robot, result.trajectory, task.line()
    pos, ori = independent_deviation(kin, line, traj)
    assert pos <= task.position_tolerance, f"position deviation {pos:.3e} m"
    assert ori <= task.orientation_tolerance, f"orientation deviation {ori:.3e} rad"
    lo, hi = kin.position_limits[:, 0], kin.position_limits[:, 1]
    assert np.all(traj.positions >= lo) and np.all(traj.positions <= hi)
    assert np.all(np.abs(traj.velocities) <= kin.velocity_limits * (1 + 1e-9))
    assert traj.times[0] == 0.0 and np.all(np.diff(traj.times) > 0)
    assert np.all(traj.velocities[0] == 0.0) and np.all(traj.velocities[-1] == 0.0)
    np.testing.assert_array_equal(traj.positions[0], task.q_start)
    rows = task_rows(kin.task_space)
    T_end = kin.fk(traj.positions[-1])
    assert np.linalg.norm(T_end[rows[rows < 3], 3] - task.T_goal[rows[rows < 3], 3]) <= 1e-6
    if kin.task_space == "pose":
        assert Rotation.from_matrix(T_end[:3, :3].T @ task.T_goal[:3, :3]).magnitude() <= 1e-6
    # The planner's own report agrees (it is what the API returns).
    assert result.deviation is not None
    assert result.deviation.max_position <= task.position_tolerance
    assert result.deviation.max_orientation <= task.orientation_tolerance
    knots = result.knots
    assert knots is not None
    k = len(knots["s"])
    assert knots["positions"].shape == (k, kin.dof) and knots["times"].shape == (k,)
    assert result.diagnostics["knot_count"] == k >= 2
    assert knots["s"][0] == 0.0 and knots["s"][-1] == 1.0 and np.all(np.diff(knots["s"]) > 0)
    assert knots["times"][0] == 0.0 and knots["times"][-1] == pytest.approx(traj.duration)
    assert np.all(np.diff(knots["times"]) > 0)
    np.testing.assert_array_equal(knots["positions"][0], traj.positions[0])
    np.testing.assert_array_equal(knots["positions"][-1], traj.positions[-1])
    assert_on_start_branch(kin, line, task.q_start, knots["positions"])
    # No jump between returned samples: a joint moves at most what its speed limit allows.
    steps = np.abs(np.diff(traj.positions, axis=0))
    assert np.all(steps <= kin.velocity_limits * np.diff(traj.times)[:, None] * 1.05 + 1e-12)


def assert_on_start_branch(kin, line: StraightLine, q_start, knot_positions) -> None:
    """Every knot is near the IK continuation of the start at its closest line point: no knot on
    another IK branch (for a 6R arm another branch is ~1 rad or more away; a redundant arm may also
    drift along its self-motion, hence the looser bound there)."""
    ref = continuation(kin, line, q_start)
    s = line.deviation(kin.fk_many(knot_positions)).s
    bound = 0.1 if kin.dof <= len(task_rows(kin.task_space)) else 0.5
    for q, si in zip(knot_positions, s, strict=True):
        gap = float(np.max(np.abs(q - reference_at(ref, float(si)))))
        assert gap < bound, f"knot at s={si:.3f} is {gap:.3f} rad off the start's branch"


# --- robots and moves -----------------------------------------------------------------------


def registry_robot(name: str):
    registry = pytest.importorskip("robots.registry")
    return registry.get(name)


def offset_move(robot, q0, dp, axis=(0.0, 0.0, 1.0), angle=0.0) -> np.ndarray:
    """Goal pose: the start's tool pose moved by ``dp`` [m] and turned by ``angle`` [rad] about the
    base-frame ``axis``."""
    T0 = robot.fk(np.asarray(q0, dtype=float))
    T = T0.copy()
    T[:3, 3] += dp
    if robot.task_space == "pose":
        rotvec = np.asarray(axis, dtype=float) / np.linalg.norm(axis) * angle
        T[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix() @ T0[:3, :3]
    return T


UR5_CASE = ((0.2, 0.15, -0.15), (1.0, 1.0, 0.0), np.radians(30))
"""The issue's UR5 move: 0.3 m along (0.2, 0.15, -0.15), 30 degrees about (1, 1, 0)."""


def ur5_task(**extra) -> CartesianTask:
    """UR5 from home: the tool moves 0.3 m and turns 30 degrees, at 1 mm / 0.01 rad."""
    robot = registry_robot("ur5")
    dp = np.array(UR5_CASE[0])
    dp *= 0.3 / np.linalg.norm(dp)
    T_goal = offset_move(robot, robot.home, dp, UR5_CASE[1], UR5_CASE[2])
    return CartesianTask(robot, robot.home.copy(), T_goal, **extra)


SHIPPED_MOVES = {
    "planar_2r": ((0.5, -0.8, 0.0), (0.0, 0.0, 1.0), 0.0),
    "puma560": ((0.1, 0.2, 0.1), (0.0, 1.0, 1.0), np.radians(30)),
    "ur5": ((0.0, 0.3, 0.0), (1.0, 0.0, 0.0), np.radians(30)),
    "panda": ((0.2, 0.1, -0.15), (1.0, 0.0, 1.0), np.radians(30)),
}


def shipped_task(name: str, **extra) -> CartesianTask:
    robot = registry_robot(name)
    dp, axis, angle = SHIPPED_MOVES[name]
    T_goal = offset_move(robot, robot.home, np.array(dp), axis, angle)
    return CartesianTask(robot, robot.home.copy(), T_goal, **extra)


# --- constructed kinematics -----------------------------------------------------------------


class WarpedGantry(DerivedKinematics):
    """An x-y gantry whose y carriage is warped along x: tip y = q2 + A sin(2 pi m q1).

    Moving x from 0 to 1 with q2 = 0 by joint interpolation, the tip strays from the line y = 0 by
    up to A, yet it is exactly on the line at x = 0.5 (and, for m = 17, at every x = k/34): the
    midpoint test passes while the segment strays elsewhere.
    """

    name = "warped_gantry"
    joint_names = ("x", "y")
    dof = 2
    task_space = "position_xy"

    def __init__(self, amplitude: float, periods: float) -> None:
        self.A, self.m = amplitude, periods
        self.position_limits = np.array([[-2.0, 2.0], [-2.0, 2.0]])
        self.velocity_limits = np.array([1.0, 1.0])
        self.acceleration_limits = np.array([5.0, 5.0])

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        qs = np.atleast_2d(qs)
        T = np.tile(np.eye(4), (len(qs), 1, 1))
        T[:, 0, 3] = qs[:, 0]
        T[:, 1, 3] = qs[:, 1] + self.A * np.sin(2 * np.pi * self.m * qs[:, 0])
        return T

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.fk_many(np.asarray(q)[None])[0]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        J = np.zeros((6, 2))
        J[0, 0] = J[1, 1] = 1.0
        J[1, 0] = self.A * 2 * np.pi * self.m * np.cos(2 * np.pi * self.m * q[0])
        return J

    def ik(
        self,
        T,
        seed,
        *,
        max_iterations=100,
        position_tolerance=1e-6,
        orientation_tolerance=1e-6,
        respect_limits=True,
    ):
        x, y = T[0, 3], T[1, 3]
        q = np.array([x, y - self.A * np.sin(2 * np.pi * self.m * x)])
        lo, hi = self.position_limits.T
        inside = bool(np.all((q >= lo) & (q <= hi)))
        return IKResult(q, inside, 0.0, 0.0, 1, inside)

    def fk_casadi(self):
        """Symbolic FK (for ``core.cartesian.knot_nlp``)."""
        import casadi as ca

        q = ca.SX.sym("q", 2)
        p = ca.vertcat(q[0], q[1] + self.A * ca.sin(2 * np.pi * self.m * q[0]), 0.0)
        return ca.Function("fk", [q], [p, ca.SX.eye(3)])


class FlippingArm(ToyPlanar2R):
    """The toy 2R arm whose IK returns the elbow branch farther from the seed."""

    def ik(self, T, seed, **options) -> IKResult:
        near = super().ik(T, seed, **options)
        far = near.positions.copy()
        far[1] = -far[1]
        far[0] = np.arctan2(T[1, 3], T[0, 3]) - np.arctan2(
            self.l2 * np.sin(far[1]), self.l1 + self.l2 * np.cos(far[1])
        )
        return IKResult(far, near.success, near.position_error, 0.0, 1, True)


def xy(x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    T[:2, 3] = x, y
    return T


def gantry_task(periods: float, amplitude: float) -> CartesianTask:
    g = WarpedGantry(amplitude, periods)
    q1 = np.array([1.0, 0.0])
    return CartesianTask(g, np.zeros(2), g.fk(q1), q_goal=q1)


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
