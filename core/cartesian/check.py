"""The checks every returned trajectory gets: joint limits, then the dense measurement (``finish``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from core.cartesian.joint_limits import outside, over_speed
from core.cartesian.measure import DeviationReport, measure_chunked, min_singular_values
from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import (
    JointLimit,
    JointRateLimit,
)
from core.kinematics import Kinematics
from core.trajectory import Trajectory


def check_limits(robot: Kinematics, traj: Trajectory, s: np.ndarray | None = None) -> None:
    """Raise JointLimit / JointRateLimit when ``traj`` leaves the robot's position or speed limits.

    ``s`` (N,) gives the path parameter of each point, for the error's location.
    """
    over = outside(traj.positions, robot.position_limits)
    if over.any():
        i, j = np.argwhere(over)[0]
        raise JointLimit(
            f"joint {robot.joint_names[j]} leaves its position limits at point {i}",
            joint=int(j),
            sample=int(i),
            s=None if s is None else float(s[i]),
        )
    fast = over_speed(traj.velocities, robot.velocity_limits)
    if fast.any():
        i, j = np.argwhere(fast)[0]
        raise JointRateLimit(
            f"joint {robot.joint_names[j]} exceeds its velocity limit at point {i}",
            joint=int(j),
            sample=int(i),
            s=None if s is None else float(s[i]),
        )


def finish(
    task: CartesianTask, result: CartesianResult, s: np.ndarray | None = None
) -> CartesianResult:
    """``result`` checked (joint limits) and measured (dense deviation, smallest singular value at
    every returned point): a new frozen result with ``deviation``, ``singular_values`` and
    ``min_singular_value`` set."""
    check_limits(task.robot, result.trajectory, s)
    deviation = measure(task, result.trajectory)
    sv = min_singular_values(task.robot, result.trajectory.positions, task.deadline)
    return replace(
        result, deviation=deviation, singular_values=sv, min_singular_value=float(sv.min())
    )


def measure(task: CartesianTask, traj: Trajectory) -> DeviationReport:
    """The dense measurement of ``traj`` against the task's line, under the task's deadline
    (``core.cartesian.measure.measure_chunked``)."""
    return measure_chunked(
        task.robot,
        task.line(),
        traj,
        task.position_tolerance,
        task.orientation_tolerance,
        task.deadline,
    )
