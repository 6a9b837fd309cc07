"""Shared builders and independent checks of the core tests (one copy each).

Tasks on the shipped robots (``ur5_task``, ``shipped_task``), on toy arms (``toy_task``, ``xy``),
constructed kinematics (``WarpedGantry``, ``FlippingArm``) and the independent deviation check
(``independent_deviation``, ``assert_valid``) used by every Cartesian method's tests.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline
from scipy.spatial.transform import Rotation, Slerp

from core.cartesian.ik_on_path import continuation, reference_at
from core.cartesian.task import CartesianResult, CartesianTask
from core.derived_kinematics import DerivedKinematics
from core.kinematics import IKResult, task_rows
from core.path.line import StraightLine
from core.trajectory import Trajectory
from tests.toy_kinematics import ToyPlanar2R

TOY_START = np.array([0.2, 1.4])
"""Start joint positions [rad] of the toy 2R arm's lines (elbow up, tip near (0.96, 1.0) m)."""


def toy_task(robot=None, goal_xy=(1.3, 0.5), **kw) -> CartesianTask:
    """The toy 2R arm (or ``robot``) from ``TOY_START`` to the tip position ``goal_xy`` [m]."""
    robot = robot or ToyPlanar2R()
    T_goal = robot.fk(TOY_START).copy()
    T_goal[:2, 3] = goal_xy
    return CartesianTask(robot=robot, q_start=TOY_START.copy(), T_goal=T_goal, **kw)


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
