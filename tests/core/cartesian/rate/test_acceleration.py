"""The rate controllers' joint accelerations, and the motion their answers return.

Issue 25 item 10: ``resolved_rate_dls`` on the Panda turning its flange 0.5 rad while moving 5 cm,
joint 7 starting 0.3 rad below its upper limit, was 422 ``joint_rate_limit``: when joint 7 reached
its limit the QP moved the others at once. Its rates are now boxed by the previous ones +- the
acceleration limits times the control period and every joint brakes before its limits; checked
on the returned positions alone (second differences) and by pinocchio FK.

Issue 26 item 9: the returned velocities were the rate held over a tick and the accelerations
finite differences of those, so consecutive samples implied 2.063 rad/s^2 against a 2.0 limit.
Now the returned motion is the C2 cubic through the returned points (acceleration linear between
them): integrating the accelerations gives the velocities, and integrating the velocities the
positions, to rounding, and the limits hold at every instant of it (computed in closed form per
interval, independent of the service's own checks).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

from core.cartesian.plan import plan
from core.cartesian.rate.qp import BRAKING_SHARE, RateLimits, braking_bounds, rate_bounds
from core.cartesian.rate.smooth import smooth_motion
from core.cartesian.task import CartesianTask
from core.trajectory import Trajectory

registry = pytest.importorskip("robots.registry")
METHODS = ("resolved_rate", "resolved_rate_dls")


def tool_pose(robot, q: np.ndarray) -> np.ndarray:
    """The tip frame by pinocchio directly."""
    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
    return data.oMf[model.getFrameId(robot.tip_frame)].homogeneous.copy()


def flange_turn_task(**kwargs) -> CartesianTask:
    """Issue 25 item 10's line: 5 cm along x and 0.5 rad about the flange's z axis, joint 7
    starting 0.3 rad below its upper limit (turning it towards the limit)."""
    robot = registry.get("panda")
    q0 = robot.home.copy()
    q0[6] = robot.position_limits[6, 1] - 0.3
    T0 = robot.fk(q0)
    T_goal = T0.copy()
    T_goal[:3, 3] += [0.05, 0.0, 0.0]
    T_goal[:3, :3] = T0[:3, :3] @ Rotation.from_rotvec([0.0, 0.0, 0.5]).as_matrix()
    return CartesianTask(robot, q0, T_goal, **kwargs)


def assert_cubic_motion(traj: Trajectory, robot, rel: float = 1e-9) -> None:
    """The returned points are the knots of a C2 cubic (acceleration linear between points) and
    that motion keeps the velocity and acceleration limits at every instant."""
    t, q, v, a = traj.times, traj.positions, traj.velocities, traj.accelerations
    h = np.diff(t)[:, None]
    scale_v, scale_q = np.abs(v).max() + 1.0, np.abs(q).max() + 1.0
    # integrals of the linear acceleration and of the quadratic velocity between points
    np.testing.assert_allclose(v[1:] - v[:-1], h * (a[:-1] + a[1:]) / 2, rtol=0, atol=rel * scale_v)
    step = h * v[:-1] + h**2 * (2 * a[:-1] + a[1:]) / 6
    np.testing.assert_allclose(q[1:] - q[:-1], step, rtol=0, atol=rel * scale_q)
    assert np.all(v[[0, -1]] == 0.0)
    # limits: acceleration is linear between points (its peak is at a point); the velocity is a
    # quadratic whose extremum, if inside an interval, is where the acceleration crosses zero
    amax, vmax = np.asarray(robot.acceleration_limits), np.asarray(robot.velocity_limits)
    assert np.all(np.abs(a) <= amax * (1 + 1e-9)), np.abs(a).max(axis=0) / amax
    cross = a[:-1] * a[1:] < 0.0
    frac = np.where(cross, a[:-1] / np.where(cross, a[:-1] - a[1:], 1.0), 0.0)
    inner = v[:-1] + a[:-1] * frac * h + (a[1:] - a[:-1]) * frac**2 * h / 2
    assert np.all(np.abs(inner) <= vmax * (1 + 1e-9)) and np.all(np.abs(v) <= vmax * (1 + 1e-9))


def test_flange_turn_with_joint_7_near_its_limit_is_within_the_acceleration_limits() -> None:
    task = flange_turn_task()
    robot = task.robot
    result = plan(task, "resolved_rate_dls")  # was 422 joint_rate_limit
    traj = result.trajectory
    t, q = traj.times, traj.positions
    # second differences of the returned positions alone (uniform 10 ms interior points)
    h = np.diff(t)
    uniform = np.flatnonzero(np.abs(h[:-1] - h[1:]) < 1e-12)
    d2 = (q[uniform + 2] - 2 * q[uniform + 1] + q[uniform]) / h[uniform, None] ** 2
    assert np.all(np.abs(d2) <= np.asarray(robot.acceleration_limits) * (1 + 1e-6))
    lo, hi = robot.position_limits.T
    assert np.all(q >= lo) and np.all(q <= hi)
    assert q[:, 6].max() > hi[6] - 0.01  # joint 7 went to its limit, the others took over
    # on the line within the tolerance at every returned point (pinocchio FK)
    T0, T1 = tool_pose(robot, task.q_start), task.T_goal
    for x in q:
        p = tool_pose(robot, x)[:3, 3]
        d = T1[:3, 3] - T0[:3, 3]
        s = np.clip((p - T0[:3, 3]) @ d / (d @ d), 0.0, 1.0)
        assert np.linalg.norm(p - T0[:3, 3] - s * d) <= task.position_tolerance
    np.testing.assert_allclose(tool_pose(robot, q[-1])[:3, 3], T1[:3, 3], atol=1e-4)
    assert_cubic_motion(traj, robot)


CASES = {
    "ur5_line": ("ur5", [0.15, -0.1, 0.1], [0.2, 0.1, -0.3]),
    "panda_line": ("panda", [0.15, -0.1, 0.1], [0.2, 0.1, -0.3]),
    "puma_short": ("puma560", [0.07, 0.0, 0.0], [0.0, 0.0, 0.0]),  # slowed for accelerations
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", list(CASES))
def test_returned_velocities_and_accelerations_are_the_exact_derivatives(method, case) -> None:
    name, dp, rotvec = CASES[case]
    robot = registry.get(name)
    T0 = robot.fk(robot.home)
    T_goal = T0.copy()
    T_goal[:3, 3] += dp
    T_goal[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix() @ T0[:3, :3]
    result = plan(CartesianTask(robot, robot.home, T_goal), method)
    assert_cubic_motion(result.trajectory, robot)


def test_smooth_motion_keeps_the_bounds_of_a_piecewise_linear_velocity() -> None:
    """Schoenberg's spline of a random continuous piecewise-linear velocity on random times:
    every velocity within max |w|, every acceleration within max |w'|, linear w reproduced."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        nodes = np.cumsum(rng.uniform(1e-3, 2e-2, 60))
        values = rng.uniform(-2.0, 2.0, (60, 2))
        slope = np.abs(np.diff(values, axis=0) / np.diff(nodes)[:, None]).max()

        def w(t: np.ndarray, nodes=nodes, values=values) -> np.ndarray:
            return np.stack([np.interp(t, nodes, values[:, j]) for j in range(2)], axis=1)

        times = np.unique(np.concatenate([[nodes[0]], rng.uniform(nodes[0], nodes[-1], 40)]))
        times = np.append(times, nodes[-1])
        q, v, a = smooth_motion(times, w, np.zeros(2))
        assert np.abs(v).max() <= np.abs(values).max() * (1 + 1e-12)
        assert np.abs(a).max() <= slope * (1 + 1e-9)
    times = np.linspace(0.0, 1.0, 11)
    q, v, a = smooth_motion(times, lambda t: np.stack([3.0 * t - 1.0], axis=1), np.array([0.5]))
    np.testing.assert_allclose(v[:, 0], 3.0 * times - 1.0, atol=1e-12)
    np.testing.assert_allclose(q[:, 0], 0.5 + 1.5 * times**2 - times, atol=1e-12)
    np.testing.assert_allclose(a[:, 0], 3.0, atol=1e-9)


def test_braking_bound_never_lets_a_joint_past_its_limit() -> None:
    """Rates anywhere within ``rate_bounds`` (with the previous rates: the acceleration box) for
    many ticks, pushed towards the upper limit: never past ``q_max - margin``, every change of
    rate within ``a_max dt``, and the bounds never empty (braking at ``BRAKING_SHARE a_max`` from
    a rate that met them meets the next)."""
    rng = np.random.default_rng(11)
    for _ in range(100):
        dof, dt = 3, float(rng.choice([1e-3, 4e-3]))
        limits = RateLimits(
            np.tile([-1.0, 1.0], (dof, 1)), rng.uniform(0.5, 3.0, dof), rng.uniform(1.0, 20.0, dof)
        )
        margin = rng.uniform(0.0, 1e-3, dof)
        q, qd = rng.uniform(-0.5, 0.5, dof), np.zeros(dof)
        for _ in range(3000):
            lower, upper = rate_bounds(q, limits, dt, qd, margin)
            assert np.all(lower <= upper + 1e-15)
            new = np.where(rng.uniform(size=dof) < 0.9, upper, rng.uniform(lower, upper))
            assert np.all(np.abs(new - qd) <= limits.acceleration * dt * (1 + 1e-12))
            q, qd = q + new * dt, new
            assert np.all(q <= 1.0 - margin + 1e-12), q
    _, brake_hi = braking_bounds(
        np.array([0.9]),
        RateLimits(np.array([[-1.0, 1.0]]), np.array([5.0]), np.array([10.0])),
        1e-3,
    )
    b, g = BRAKING_SHARE * 10.0, 0.1  # qd dt + qd^2 / (2 b) = g
    assert brake_hi[0] * 1e-3 + brake_hi[0] ** 2 / (2 * b) == pytest.approx(g, rel=1e-12)


def test_smooth_motion_ends_where_asked_within_the_same_bounds() -> None:
    """A coarse grid (the sweep's 0.197 s sample period) leaves the smoothed motion off the
    controller's end by about h^2/8 of its change of acceleration; with ``q_end`` it ends there,
    rest at both ends kept, every velocity and acceleration within the limits given."""
    nodes = np.linspace(0.0, 1.0, 1001)
    w = np.sin(np.pi * nodes)[:, None] * np.array([1.0, -0.5])  # rest to rest

    def velocity(t: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(t, nodes, w[:, j]) for j in range(2)], axis=1)

    end = np.trapezoid(w, nodes, axis=0)
    times = np.append(np.arange(0.0, 1.0, 0.197), 1.0)
    q = smooth_motion(times, velocity, np.zeros(2))[0]
    assert np.abs(q[-1] - end).max() > 1e-4  # the smoothing's error at the end
    limits = (np.array([1.1, 0.6]), np.array([4.0, 2.0]))
    q2, v2, a2 = smooth_motion(times, velocity, np.zeros(2), end, limits)
    np.testing.assert_allclose(q2[-1], end, rtol=0, atol=1e-15)
    assert np.abs(v2[[0, -1]]).max() < 1e-15
    assert np.all(np.abs(v2) <= limits[0]) and np.all(np.abs(a2) <= limits[1])
    # within limits it cannot meet, a joint keeps the smoothing's error
    tight = (np.array([1.0, 0.6]), np.array([4.0, 2.0]))
    q3 = smooth_motion(times, velocity, np.zeros(2), end, tight)[0]
    assert abs(q3[-1, 0] - end[0]) > 1e-4 and q3[-1, 1] == end[1]
    h = np.diff(times)[:, None]
    np.testing.assert_allclose(v2[1:] - v2[:-1], h * (a2[:-1] + a2[1:]) / 2, atol=1e-12)
