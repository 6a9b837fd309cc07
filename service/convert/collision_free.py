"""``POST /v1/trajectories/collision_free``: request -> ``core.motion.plan.MotionTask`` and the
robot's clearance (``robots.validity.GroupedClearance``), ``MotionResult`` -> response.

The start must hold one value per joint inside the position limits (422 ``validation`` /
``joint_limit`` naming the field); a goal pose becomes every IK solution
(``core.motion.goals.pose_goals``); ``max_planning_time`` may not exceed the request's time
budget. Limits: the request's lists over the robot's (``service.convert.joint.joint_limits``).
"""

from __future__ import annotations

import time

import numpy as np
from starlette.responses import Response

from core.budget import Deadline
from core.errors import InputError
from core.limits import JointLimits, check_positions
from core.motion.goals import Goals, pose_goals
from core.motion.plan import MotionResult, MotionTask
from core.timing.path_constraints import Effort, PathLimits
from robots.model import Robot
from service.convert.dynamics import dynamics_of, effort_inputs, gravity_of
from service.convert.environment import clearance_diagnostics
from service.convert.joint import joint_limits
from service.convert.robot import robot_and_names
from service.encoding import base_diagnostics, check_finite, json_response, trajectory_body
from service.schemas.collision_free import CollisionFreeRequest

SEARCH_RESERVE = 1.0
"""[s] Of the request's time budget, kept for what follows the search (shortening, smoothing,
timing, the continuous check, encoding)."""


def motion_task(
    body: CollisionFreeRequest, robot: Robot, deadline: Deadline, max_points: int, budget_s: float
) -> MotionTask:
    """The core task of a request (start and goal checked against ``robot``, the request's robot
    with its ``tool``); the limits ``time_optimal`` keeps along the path (``PathLimits``) built
    here."""
    _, names = robot_and_names(
        body.robot, len(body.start.positions), ("start", "positions"), body.tool
    )
    limits = joint_limits(body.limits, robot)
    q_start = np.asarray(body.start.positions, dtype=float)
    check_positions(q_start[None], limits, names, field=("start", "positions"))
    for field_name in ("velocity", "acceleration", "jerk"):
        given = getattr(body.limits, field_name, None) if body.limits is not None else None
        if given is not None and len(given) != robot.dof:
            raise InputError(
                f"limits.{field_name} needs {robot.dof} values, one per joint",
                field=("limits", field_name),
            )
    if body.goal.positions is not None:
        q_goal = np.asarray(body.goal.positions, dtype=float)
        if q_goal.shape != (robot.dof,):
            raise InputError(
                f"goal.positions needs {robot.dof} values, one per joint",
                field=("goal", "positions"),
            )
        check_positions(q_goal[None], limits, names, field=("goal", "positions"))
        goals = Goals(q_goal[None], (robot.configuration(q_goal),), False)
    else:
        assert body.goal.pose is not None  # the schema gives exactly one
        goals = pose_goals(
            robot, body.goal.pose.as_matrix(), q_start, body.goal.configuration, deadline
        )
    if body.max_planning_time is not None and body.max_planning_time > budget_s:
        raise InputError(
            f"max_planning_time may be at most the request's time budget, {budget_s:g} s",
            field=("max_planning_time",),
            extra={"budget_s": budget_s},
        )
    planning = budget_s if body.max_planning_time is None else float(body.max_planning_time)
    planning = max(min(planning, deadline.remaining() - SEARCH_RESERVE), 0.0)
    effort = effort_inputs(body, robot, robot.dof)
    return MotionTask(
        q_start=q_start,
        goals=goals,
        limits=limits,
        timing=body.timing,
        seed=body.seed,
        max_planning_time=planning,
        sample_period=body.sample_period,
        samples=body.samples,
        max_points=max_points,
        joint_names=names,
        deadline=deadline,
        path_limits=path_limits(limits, effort),
        effort=effort,
        dynamics=dynamics_of(robot),
        gravity=gravity_of(body, robot),
    )


def path_limits(limits: JointLimits, effort: Effort | None = None) -> PathLimits | None:
    """What ``time_optimal`` keeps along the path: the joint velocity and acceleration limits and
    the request's ``effort`` (None when the robot lacks a velocity or acceleration limit: core
    answers which)."""
    if limits.velocity is None or limits.acceleration is None:
        return None
    return PathLimits(limits.velocity, limits.acceleration, effort=effort)


def response(
    result: MotionResult,
    warnings: tuple[str, ...],
    started: float,
    time_format: str,
) -> Response:
    """The answer: the trajectory, its diagnostics (``planner``, ``path_length``,
    ``path_length_ratio``, ``certified``, the usual check's ``min_clearance``, ``closest`` and
    ``clearance_profile``) and ``waypoints``."""
    traj = result.trajectory
    check_finite(traj)
    diag = base_diagnostics(traj, "collision_free", (time.perf_counter() - started) * 1e3)
    diag.update(
        warnings=list(warnings),
        timing=result.timing,
        planner=result.planner.as_dict(),
        path_length=result.path_length,
        path_length_ratio=result.path_length_ratio,
        certified=True,
        goal_configuration=result.configuration,
        **clearance_diagnostics(result.clearance, warnings),
    )
    if result.peak_effort is not None:
        diag["peak_effort"] = result.peak_effort
    waypoints = np.asarray(result.waypoints, dtype=float).tolist()
    return json_response(
        trajectory_body(traj, diag, time_format, encoded=True, waypoints=waypoints)
    )
