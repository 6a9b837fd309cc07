"""The vectorized paths added for speed (issue 7) agree with the ones they stand in for: the batched
IK of the sampled method's returned points, the numpy rotation log and slerp of the line, the pseudo-
inverse built from one SVD."""

from __future__ import annotations

import numpy as np
import pytest

import core.cartesian.methods.sampled as sampled
from core.cartesian.path_rates import path_rates
from core.cartesian.plan import plan
from core.cartesian.task import CartesianTask
from core.path.line import StraightLine
from robots import registry


def tasks() -> list[CartesianTask]:
    ur5, panda = registry.get("ur5"), registry.get("panda")
    q_goal = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
    start = np.array([0.0, -1.047, 1.571, -2.094, -1.571, 0.0])
    T = panda.fk(panda.home)
    T[:3, 3] += [0.1, -0.1, 0.05]
    return [
        CartesianTask(ur5, start, ur5.fk(q_goal), q_goal=q_goal, samples=200),
        CartesianTask(panda, panda.home, T, samples=300),
        CartesianTask(panda, panda.home, T),
    ]


@pytest.mark.parametrize("task", tasks(), ids=lambda t: f"{t.robot.name}-{t.samples}")
def test_batched_returned_points_equal_the_one_point_path(task, monkeypatch) -> None:
    fast = plan(task, "sampled")
    monkeypatch.setattr(sampled, "BATCH_MIN_POINTS", 10**9)  # the one-point path only
    slow = plan(task, "sampled")
    assert fast.trajectory.positions.shape == slow.trajectory.positions.shape
    assert np.abs(fast.trajectory.positions - slow.trajectory.positions).max() <= 1e-7
    assert fast.diagnostics["ik_calls"] == slow.diagnostics["ik_calls"]
    assert abs(fast.deviation.max_position - slow.deviation.max_position) <= 1e-9


def test_path_rates_pseudo_inverse_equals_numpys() -> None:
    robot = registry.get("panda")
    qs = np.random.default_rng(8).uniform(-1.0, 1.0, (40, robot.dof))
    T0 = robot.fk(robot.home)
    T1 = T0.copy()
    T1[:3, 3] += [0.1, 0.0, -0.1]
    line = StraightLine(T0, T1)
    rates = path_rates(robot, line, qs, second_order=False)
    V = line.twist(np.array([1.0]))[0]
    expected = np.array([np.linalg.pinv(robot.jacobian(q)) @ V for q in qs])
    np.testing.assert_allclose(rates.dq_ds, expected, rtol=0, atol=1e-9)
    sigma = np.array([np.linalg.svd(robot.jacobian(q), compute_uv=False)[-1] for q in qs])
    np.testing.assert_allclose(rates.sigma, sigma, rtol=1e-9, atol=1e-12)


def test_sampled_trajectories_are_c_contiguous() -> None:
    """The encoder writes row views of C-contiguous arrays without copying them (a 100,000-point,
    64-joint response stays within its memory bound): sampling must hand it that layout."""
    from core.joint.point_to_point import PointToPoint, plan_joint
    from core.joint.splines import plan_spline

    q1 = np.linspace(-1.0, 1.0, 7)
    for kind in ("quintic", "cubic", "linear"):
        tr = plan_joint(kind, PointToPoint.create(np.zeros(7), q1), duration=2.0, samples=50)
        arrays = (tr.trajectory.positions, tr.trajectory.velocities, tr.trajectory.accelerations)
        assert all(a.flags["C_CONTIGUOUS"] for a in arrays), kind
    waypoints = np.cumsum(np.random.default_rng(9).uniform(-0.3, 0.3, (12, 7)), axis=0)
    sp = plan_spline(waypoints, times=np.linspace(0.0, 6.0, 12), samples=5000).trajectory
    assert all(a.flags["C_CONTIGUOUS"] for a in (sp.positions, sp.velocities, sp.accelerations))
