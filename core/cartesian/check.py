"""The checks every returned trajectory gets: joint limits, then the dense measurement (``finish``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from core.cartesian.ik_on_path import label_change
from core.cartesian.measure import DeviationReport, measure_chunked, min_singular_values
from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import (
    BranchFlip,
    Infeasible,
    JointLimit,
    JointRateLimit,
)
from core.kinematics import Kinematics
from core.limits import outside, over_speed
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
    """``result`` checked (joint limits, the start's configuration label) and measured (dense deviation, smallest singular value at
    every returned point): a new frozen result with ``deviation``, ``singular_values`` and
    ``min_singular_value`` set."""
    check_limits(task.robot, result.trajectory, s)
    deviation = measure(task, result.trajectory)
    flip = check_labels(task, result.trajectory, s, deviation) if task.keep_configuration else None
    if flip is not None:
        if not task.allow_violations:
            raise flip
        result = replace(result, warnings=(*result.warnings, f"{flip} (allow_violations)"))
    sv = result.singular_values  # (a method that computed them at the returned points)
    if sv is None or len(sv) != len(result.trajectory.times):
        sv = min_singular_values(task.robot, result.trajectory.positions, task.deadline)
    return replace(
        result, deviation=deviation, singular_values=sv, min_singular_value=float(sv.min())
    )


def check_labels(
    task: CartesianTask,
    traj: Trajectory,
    s: np.ndarray | None = None,
    deviation: DeviationReport | None = None,
) -> BranchFlip | None:
    """``BranchFlip`` at the first returned point, or midpoint between two (the cubic Hermite
    spline a controller follows, at the middle of each interval), whose configuration label differs
    from the start's (robots with labels; one batched ``configurations`` call of 2N - 1 rows). Its
    ``s``: from ``s`` (N,), else the dense measurement's closest path parameter at that point (a
    midpoint: the mean of its ends'). None when every point keeps the start's label (or the robot
    has none). ``finish`` raises it, or with ``allow_violations`` returns the plan with it as a
    warning (the DLS may pass a singularity on purpose)."""
    label = task.robot.configuration(np.asarray(task.q_start, dtype=float))
    if label is None:
        return None
    q, n = traj.positions, len(traj.times)
    if n > 1:
        t_mid = 0.5 * (traj.times[:-1] + traj.times[1:])
        mid = CubicHermiteSpline(traj.times, q, traj.velocities, axis=0)(t_mid)
        q = np.insert(q, np.arange(1, n), mid, axis=0)  # p0, m0, p1, m1, ..., p_{n-1}
    off = np.flatnonzero(np.array(task.robot.configurations(q)) != label)
    if not len(off):
        return None
    if s is not None:
        at_points = np.asarray(s, dtype=float)
    elif deviation is not None and n > 1:
        at_points = deviation.s[:: (len(deviation.s) - 1) // (n - 1)]
    else:
        at_points = np.zeros(n)
    k = int(off[0])
    return label_change(float(0.5 * (at_points[k // 2] + at_points[(k + 1) // 2])), label)


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


VIOLATION_SLACK = 1e-6
"""Relative slack of the 200 rule on the tolerances and acceleration limits (rounding of the
dense measurement and of finite-difference accelerations)."""


def enforce(task: CartesianTask, result: CartesianResult) -> CartesianResult:
    """The rule of every method (issue 19): a 200 is within its tolerance between the returned
    points and within the robot's acceleration limits; otherwise ``Infeasible`` (the deviation) or
    ``JointRateLimit`` (an acceleration), each naming what to change, unless the task says
    ``allow_violations`` (then ``result`` as it is, its warnings saying where)."""
    dev = result.deviation
    if task.allow_violations or dev is None:
        return result
    over_p = dev.max_position > task.position_tolerance * (1.0 + VIOLATION_SLACK)
    over_o = dev.max_orientation > task.orientation_tolerance * (1.0 + VIOLATION_SLACK)
    if over_p or over_o:
        worst = np.argmax(
            np.maximum(
                dev.position / task.position_tolerance, dev.orientation / task.orientation_tolerance
            )
        )
        raise Infeasible(
            f"between its returned points the trajectory strays up to {dev.max_position:.3g} m / "
            f"{dev.max_orientation:.3g} rad from the line (tolerance {task.position_tolerance:g} m "
            f"/ {task.orientation_tolerance:g} rad): give more samples or a smaller sample_period, "
            "or set allow_violations to accept it",
            s=float(dev.s[worst]),
            extra={
                "max_position_deviation": dev.max_position,
                "max_orientation_deviation": dev.max_orientation,
            },
        )
    ratio = result.trajectory.peak_acceleration / np.asarray(task.robot.acceleration_limits)
    j = int(np.argmax(ratio))
    if ratio[j] > 1.0 + VIOLATION_SLACK:
        raise JointRateLimit(
            f"joint {task.robot.joint_names[j]} accelerates at {ratio[j]:.3g} times its limit: "
            "give a longer duration or lower tool speeds, or set allow_violations to accept it",
            joint=j,
            extra={"limit": "acceleration", "ratio": float(ratio[j])},
        )
    return result
