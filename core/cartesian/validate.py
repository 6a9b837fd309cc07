"""Entry checks every Cartesian method shares, in one place (``validated_line``)."""

from __future__ import annotations

import numpy as np

from core.cartesian.task import CartesianTask
from core.errors import (
    InputError,
    JointLimit,
)
from core.limits import inside, worst_joint
from core.path import Path
from core.timing import TIMING_LAWS


def validated_line(task: CartesianTask) -> Path:
    """The task's path after the entry checks every method shares (``InputError`` / ``JointLimit``
    naming the field): tolerances, duration, speeds and jerks finite and > 0; a known speed
    profile; start and goal positions finite, one per joint and inside the joint limits; a goal
    pose other than the start pose; for an arc, a proper circle (``path.*``)."""
    robot = task.robot
    for where, value in (
        (("tolerance", "position"), task.position_tolerance),
        (("tolerance", "orientation"), task.orientation_tolerance),
        (("duration",), task.duration),
        (("max_linear_speed",), task.max_linear_speed),
        (("max_angular_speed",), task.max_angular_speed),
        (("max_linear_jerk",), task.max_linear_jerk),
        (("max_angular_jerk",), task.max_angular_jerk),
        (("max_linear_acceleration",), task.max_linear_acceleration),
        (("max_angular_acceleration",), task.max_angular_acceleration),
    ):
        if value is not None and not (np.isfinite(value) and value > 0.0):
            raise InputError(f"{'.'.join(where)} must be a finite number > 0", field=where)
    if task.speed_profile not in TIMING_LAWS:
        raise InputError(
            f"speed_profile must be one of {', '.join(TIMING_LAWS)}", field=("speed_profile",)
        )
    for name, q, s in (("start", task.q_start, 0.0), ("goal", task.q_goal, 1.0)):
        if q is None:
            continue
        if np.shape(q) != (robot.dof,) or not np.all(np.isfinite(q)):
            raise InputError(
                f"{name}.positions needs {robot.dof} finite values, one per joint",
                field=(name, "positions"),
            )
        if not inside(q, robot.position_limits):
            j = worst_joint(q, robot.position_limits)
            raise JointLimit(
                f"{name}.positions puts joint {robot.joint_names[j]} outside its limits",
                field=(name, "positions", j),
                s=s,
                joint=j,
            )
    line = task.line()
    if line.length < 1e-9 and line.angle < 1e-9:
        raise InputError(
            "the goal pose is the start pose: there is no path to plan", field=("goal",)
        )
    return line
