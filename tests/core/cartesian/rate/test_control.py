"""Resolved-rate control: tracking, the wrist singularity, position limits, lag, partial plans.

The toy 2R arm covers the controller's logic without pinocchio; the shipped UR5 and PUMA 560
(robots.registry) cover the issue's cases: tracking away from singularities, and the line through
the PUMA's wrist singularity that the pseudo-inverse refuses and the DLS completes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core.budget import Deadline
from core.cartesian.plan import plan
from core.cartesian.rate.control import simulate
from core.cartesian.task import CartesianTask
from core.errors import (
    InputError,
    JointLimit,
    JointRateLimit,
    PlanningError,
    Singularity,
    TimeBudgetExceeded,
    TooLarge,
)
from tests.core.conftest import xy
from tests.toy_kinematics import ToyPlanar2R

METHODS = ("resolved_rate", "resolved_rate_dls")


def _check_response(task: CartesianTask, result) -> None:
    """Every returned point within the limits, rest at both ends, times strictly increasing."""
    traj, robot = result.trajectory, task.robot
    lo, hi = robot.position_limits.T
    assert np.all(traj.positions >= lo) and np.all(traj.positions <= hi)
    assert np.all(np.abs(traj.velocities) <= robot.velocity_limits)
    assert np.all(traj.velocities[[0, -1]] == 0.0)
    assert traj.times[0] == 0.0 and np.all(np.diff(traj.times) > 0)
    assert len(traj.times) <= 100_000
    for array in (traj.positions, traj.velocities, traj.accelerations):
        assert np.all(np.isfinite(array))


@pytest.fixture(scope="module")
def registry():
    return pytest.importorskip("robots.registry")


@pytest.mark.parametrize("method", METHODS)
def test_toy_arm_tracks_line(method):
    robot = ToyPlanar2R()
    task = CartesianTask(robot, np.array([0.3, 1.2]), xy(0.6, 1.0), duration=2.0)
    result = plan(task, method)
    _check_response(task, result)
    # the duration, and the last rates' ramp to rest (one control tick)
    assert result.fraction == 1.0 and result.trajectory.duration == pytest.approx(2.001)
    assert result.deviation.max_position <= 1e-4
    assert np.linalg.norm(robot.fk(result.trajectory.positions[-1])[:2, 3] - [0.6, 1.0]) <= 1e-4
    assert result.warnings == ()


@pytest.mark.parametrize("name", ["ur5", "panda"])
@pytest.mark.parametrize("method", METHODS)
def test_arm_tracks_line_away_from_singularities(registry, method, name):
    robot = registry.get(name)
    T0 = robot.fk(robot.home)
    T_goal = T0.copy()
    T_goal[:3, 3] += [0.15, -0.1, 0.1]
    T_goal[:3, :3] = Rotation.from_rotvec([0.2, 0.1, -0.3]).as_matrix() @ T0[:3, :3]
    task = CartesianTask(robot, robot.home, T_goal, duration=2.0)
    result = plan(task, method)
    _check_response(task, result)
    assert result.fraction == 1.0
    assert result.deviation.max_position <= 1e-3 and result.deviation.max_orientation <= 1e-2
    d = result.diagnostics
    assert d["max_tracking_error_position"] <= 1e-3
    assert d["max_tracking_error_orientation"] <= 1e-2
    assert d["active_limit_steps"] == 0 and d["min_singular_value_met"] > 0.1
    if method == "resolved_rate_dls":
        assert d["qp_iterations_max"] <= 100 and d["qp_fallback_steps"] == 0


def _puma_wrist_task(registry, **kwargs) -> CartesianTask:
    """A line on which the PUMA's q5 goes from +0.25 to -0.25 rad: it passes the wrist singularity."""
    robot = registry.get("puma560")
    q_start = np.array([0.0, 0.6, -2.6, 0.3, 0.25, 0.0])
    T_goal = robot.fk(np.array([0.2, 0.7, -2.4, 0.32, -0.25, 0.0]))
    return CartesianTask(robot, q_start, T_goal, duration=2.0, allow_violations=True, **kwargs)


def test_puma_wrist_singularity_pinv_refuses_dls_completes(registry):
    task = _puma_wrist_task(registry)
    with pytest.raises((Singularity, JointRateLimit)) as info:
        plan(task, "resolved_rate")
    assert 0.2 < info.value.s < 0.8

    result = plan(task, "resolved_rate_dls")
    _check_response(task, result)
    assert result.fraction == 1.0
    q5 = result.trajectory.positions[:, 4]
    assert q5.max() > 0.2 and q5.min() < -0.2  # it went through the wrist singularity
    d = result.diagnostics
    assert d["min_singular_value_met"] < 1e-3 and d["max_damping"] > 0.0
    # The deviation accepted near the singularity is measured and reported.
    dev = result.deviation
    assert 0.0 < dev.max_position < 5e-3 and dev.max_orientation < 0.05
    assert 0.2 < d["max_deviation_s"] < 0.8
    assert any("singularity" in w for w in result.warnings)
    assert any("accepted a deviation" in w for w in result.warnings)


def test_pinv_partial_prefix_ends_at_rest(registry):
    task = _puma_wrist_task(registry, allow_partial=True)
    result = plan(task, "resolved_rate")
    _check_response(task, result)
    assert 0.2 < result.fraction < 0.8
    assert isinstance(result.failure, (Singularity, JointRateLimit))
    assert np.all(result.trajectory.peak_acceleration <= task.robot.acceleration_limits * 1.5)


class _LimitedToy(ToyPlanar2R):
    def __init__(self) -> None:
        super().__init__()
        self.position_limits = np.array([[-np.pi, np.pi], [0.8, np.pi]])


def _limit_task(**kwargs) -> CartesianTask:
    """The line asks the elbow to open to 0.4 rad; its limit is 0.8 rad."""
    robot = _LimitedToy()
    T_goal = robot.fk(np.array([0.2, 0.4]))
    return CartesianTask(
        robot, np.array([0.3, 1.2]), T_goal, duration=2.0, allow_violations=True, **kwargs
    )


def test_joint_stops_at_position_limit_and_never_passes_it():
    task = _limit_task()
    run = simulate(task, "resolved_rate_dls")
    elbow = run.positions[:, 1]
    # braked to a stop short of the limit (by the room the returned motion's smoothing needs),
    # never past it, and held there
    assert 0.8 < elbow.min() <= 0.8 + 1e-3
    held = elbow <= elbow.min() + 1e-9
    assert held.sum() > 100 and np.all(run.rates[held, 1] >= -1e-6)
    assert isinstance(run.failure, JointLimit) and run.failure.joint == 1
    with pytest.raises(JointLimit) as info:
        plan(task, "resolved_rate_dls")
    assert 0.5 < info.value.s < 0.9
    with pytest.raises(JointLimit):
        plan(task, "resolved_rate")

    partial = plan(dataclasses.replace(task, allow_partial=True), "resolved_rate_dls")
    _check_response(task, partial)
    assert 0.5 < partial.fraction < 0.9
    assert partial.deviation.max_position <= task.position_tolerance


def test_velocity_limits_slow_the_dls_along_the_line():
    robot = ToyPlanar2R()
    task = CartesianTask(
        robot, np.array([0.3, 1.2]), xy(-0.6, 1.0), duration=0.3, allow_violations=True
    )
    with pytest.raises(JointRateLimit):
        plan(task, "resolved_rate")
    result = plan(task, "resolved_rate_dls")
    _check_response(task, result)
    d = result.diagnostics
    assert result.fraction == 1.0 and result.trajectory.duration > 0.5
    assert d["min_time_scale"] < 0.5 and d["settle_time"] > 0.0
    assert result.deviation.max_position <= task.position_tolerance
    assert any("slowed the tool" in w for w in result.warnings)


def test_goal_outside_workspace_fails_with_location():
    robot = ToyPlanar2R()
    task = CartesianTask(robot, np.array([0.3, 1.2]), xy(1.5, 1.2), duration=2.0)
    for method in METHODS:
        with pytest.raises(PlanningError) as info:
            plan(task, method)
        assert info.value.code in ("singularity", "joint_rate_limit")
        assert 0.5 < info.value.s < 1.0
    partial = plan(dataclasses.replace(task, allow_partial=True), "resolved_rate_dls")
    _check_response(task, partial)
    assert 0.5 < partial.fraction < 1.0


def test_sampling_controls():
    robot = ToyPlanar2R()
    base = CartesianTask(
        robot, np.array([0.3, 1.2]), xy(0.6, 1.0), duration=1.0, allow_violations=True
    )
    result = plan(dataclasses.replace(base, samples=7), "resolved_rate_dls")
    assert len(result.trajectory.times) == 7
    fine = plan(dataclasses.replace(base, sample_period=4e-4, control_period=2e-3), "resolved_rate")
    assert len(fine.trajectory.times) == 2506  # 1 s and the last rates' ramp to rest (a tick)
    assert fine.diagnostics["control_period"] == pytest.approx(2e-3)
    _check_response(base, fine)
    timed = plan(dataclasses.replace(base, duration=None, max_linear_speed=0.2), "resolved_rate")
    length = np.linalg.norm(robot.fk(base.q_start)[:2, 3] - [0.6, 1.0])
    trapezoid = length / 0.2 + 0.2 / 1.0  # cruise at 0.2 m/s, default 1 m/s^2
    assert timed.trajectory.duration == pytest.approx(trapezoid, rel=1e-3)


def test_input_errors_and_bounds():
    robot = ToyPlanar2R()
    task = CartesianTask(robot, np.array([0.3, 1.2]), xy(0.6, 1.0), duration=1.0)
    with pytest.raises(InputError) as info:
        plan(dataclasses.replace(task, solver="no_such_solver"), "resolved_rate_dls")
    assert info.value.field == ("solver",)
    with pytest.raises(InputError) as info:
        plan(dataclasses.replace(task, control_period=0.0), "resolved_rate")
    assert info.value.field == ("control_period",)
    with pytest.raises(TooLarge):
        plan(dataclasses.replace(task, duration=5e3), "resolved_rate")
    with pytest.raises(TimeBudgetExceeded):
        plan(dataclasses.replace(task, deadline=Deadline(0.0)), "resolved_rate_dls")
    with pytest.raises(InputError) as info:
        plan(dataclasses.replace(task, T_goal=robot.fk(task.q_start)), "resolved_rate_dls")
    assert info.value.field == ("goal",)
    with pytest.raises(JointLimit) as info:
        plan(dataclasses.replace(task, q_start=np.array([0.3, 3.5])), "resolved_rate")
    assert info.value.field == ("start", "positions", 1) and info.value.s == 0.0


def test_other_qp_solver_through_qpsolvers():
    import qpsolvers

    others = [s for s in ("daqp", "quadprog", "proxqp") if s in qpsolvers.available_solvers]
    if not others:
        pytest.skip("no QP solver besides OSQP is installed")
    robot = ToyPlanar2R()
    task = CartesianTask(
        robot,
        np.array([0.3, 1.2]),
        xy(0.6, 1.0),
        duration=0.5,
        solver=others[0],
        allow_violations=True,
    )
    result = plan(task, "resolved_rate_dls")
    reference = plan(dataclasses.replace(task, solver="osqp"), "resolved_rate_dls")
    assert result.diagnostics["solver"] == others[0]
    assert np.allclose(result.trajectory.positions, reference.trajectory.positions, atol=1e-6)


def test_singular_start_pinv_refuses_at_s0_dls_moves_off():
    robot = ToyPlanar2R()  # q = (0, 0): the arm fully stretched, rank 1
    task = CartesianTask(
        robot, np.zeros(2), xy(1.2, 0.3), duration=1.0, allow_partial=True, allow_violations=True
    )
    partial = plan(task, "resolved_rate")
    assert isinstance(partial.failure, Singularity) and partial.failure.s == 0.0
    assert partial.fraction == 0.0 and len(partial.trajectory.times) == 2
    assert np.all(partial.trajectory.positions == 0.0)
    result = plan(dataclasses.replace(task, allow_partial=False), "resolved_rate_dls")
    _check_response(task, result)
    assert result.fraction == 1.0 and result.diagnostics["max_damping"] > 0.0
