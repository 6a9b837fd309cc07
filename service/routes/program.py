"""POST /v1/trajectories/program: PTP, LIN and CIRC segments in one trajectory, blended.

Thin route: schema -> ``ProgramTask`` -> ``core.program.plan.plan_program`` -> response. Plain
``def``: planning is CPU-bound, so FastAPI runs it in its thread pool.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from core.budget import Deadline
from core.errors import PlanningError, TooLarge
from core.kinematics import Clearance, Kinematics
from core.limits import entry_positions
from core.program.plan import ProgramResult, plan_program
from core.program.segments import ProgramTask, Segment
from robots import registry
from robots.model import Robot
from robots.validity import GroupedClearance
from service import deps
from service.convert.cartesian import failure_body
from service.convert.dynamics import dynamics_of, effort_inputs, gravity_of
from service.convert.environment import (
    clearance_diagnostics,
    collision_check,
    inline_urdf,
    unchecked_warnings,
)
from service.convert.robot import with_tool
from service.encoding import (
    base_diagnostics,
    check_finite,
    json_response,
    ros_durations,
    trajectory_body,
)
from service.schemas.common import TIME_FORMAT_QUERY, TimeFormat, trajectory_responses
from service.schemas.program import CircSegment, ProgramRequest, ProgramResponse, PtpSegment

router = APIRouter(prefix="/v1/trajectories", tags=["program"])


def _joints(robot: Kinematics, values: list[float], loc: tuple[str | int, ...]) -> np.ndarray:
    """Joint positions at ``loc``: one per joint, inside the limits (``entry_positions``); a
    segment's names its ``segment``."""
    segment: dict[str, object] = {"segment": loc[1]} if loc[0] == "segments" else {}
    return entry_positions(values, robot.position_limits, robot.joint_names, loc, extra=segment)


def planner_clearance(body: ProgramRequest, check: Clearance | None) -> GroupedClearance | None:
    """The collision-free planner's view of the request's collision object, when the program has
    an environment and a PTP segment asks for the planner."""
    asks = any(isinstance(s, PtpSegment) and s.planner is not None for s in body.segments)
    if not asks or body.environment is None or check is None:
        return None
    return GroupedClearance(check)  # type: ignore[arg-type]


def task_from_request(
    body: ProgramRequest,
    robot: Robot,
    deadline: Deadline,
    check: Clearance | None = None,
) -> ProgramTask:
    """The core task of a request: joint arrays checked against the robot; ``check``: the
    request's collision object; effort limits and gravity (``service.convert.dynamics``)."""
    segments = []
    for i, s in enumerate(body.segments):
        loc = ("segments", i, "goal", "positions")
        goal_q = None if s.goal.positions is None else _joints(robot, s.goal.positions, loc)
        goal_T = None if s.goal.pose is None else s.goal.pose.as_matrix()
        common: dict[str, Any] = {
            "goal_pose": goal_T,
            "goal_positions": goal_q,
            "blend_radius": s.blend_radius,
            "velocity_scale": s.velocity_scale,
            "acceleration_scale": s.acceleration_scale,
        }
        if isinstance(s, PtpSegment):
            segments.append(
                Segment(
                    "ptp",
                    configuration=s.goal.configuration,
                    profile=s.profile,
                    planner=s.planner,
                    **common,
                )
            )
            continue
        extra: dict[str, Any] = {}
        if isinstance(s, CircSegment):
            extra = {
                "interim": None if s.interim is None else np.array(s.interim),
                "center": None if s.center is None else np.array(s.center),
            }
        segments.append(
            Segment(
                s.type,
                max_linear_speed=s.max_linear_speed,
                max_angular_speed=s.max_angular_speed,
                speed_profile=s.speed_profile,
                max_linear_jerk=s.max_linear_jerk,
                max_angular_jerk=s.max_angular_jerk,
                max_linear_acceleration=s.max_linear_acceleration,
                max_angular_acceleration=s.max_angular_acceleration,
                position_tolerance=s.tolerance.position,
                orientation_tolerance=s.tolerance.orientation,
                method=s.method,
                **common,
                **extra,
            )
        )
    return ProgramTask(
        robot=robot,
        q_start=_joints(robot, body.start.positions, ("start", "positions")),
        segments=tuple(segments),
        sample_period=body.sample_period,
        samples=body.samples,
        allow_partial=body.allow_partial,
        deadline=deadline,
        collision_check=check,
        timing=body.timing,
        seed=body.seed,
        planner_clearance=planner_clearance(body, check),
        effort=effort_inputs(body, robot, robot.dof),
        dynamics=dynamics_of(robot),
        gravity=gravity_of(body, robot),
    )


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def result_body(
    result: ProgramResult,
    compute_time_ms: float,
    time_format: str = "float",
    unchecked: tuple[str, ...] = (),
) -> dict[str, Any]:
    """The response document: trajectory, diagnostics, ``segments``; ``unchecked``: what the
    collision check could not see."""
    traj = result.trajectory
    diag = base_diagnostics(traj, "program", compute_time_ms)
    diag["warnings"] = [*result.warnings, *unchecked]
    diag["fraction"] = result.fraction
    diag.update({k: _finite(v) for k, v in result.diagnostics.items()})  # peak_effort too
    diag.update(clearance_diagnostics(result.clearance, unchecked))
    if result.failure is not None:
        err: PlanningError = result.failure
        diag["failure"] = {"segment": err.extra.get("segment"), **failure_body(err)}

    def stamp(t: float) -> Any:
        return ros_durations(np.array([t]))[0] if time_format == "ros" else t

    segments = [
        {
            "index": s.index,
            "type": s.type,
            "start_time": stamp(s.start_time),
            "end_time": stamp(s.end_time),
            **(
                {
                    "blend_out": {
                        "start_time": stamp(s.blend_out[0]),
                        "end_time": stamp(s.blend_out[1]),
                    }
                }
                if s.blend_out
                else {}
            ),
            "diagnostics": {k: _finite(v) for k, v in s.diagnostics.items()},
        }
        for s in result.segments
    ]
    return trajectory_body(traj, diag, time_format, segments=segments)


@router.post(
    "/program",
    responses=trajectory_responses(ProgramResponse),
    summary="Motion program: PTP, LIN and CIRC segments as one trajectory, blended at corners",
    description=(
        "One trajectory from `start` through every segment's goal in order (at most 100 segments). "
        "PTP moves in joint space; LIN on the tool's straight line; CIRC on the circle arc through "
        "`interim` or about `center`. With `blend_radius` r > 0 the motion leaves a segment where "
        "the tool enters the sphere of radius r about its goal and joins the next where it leaves "
        "it, without stopping: q, q' and q'' are continuous everywhere and the joint velocity and "
        "acceleration limits (times each segment's scales) hold. Without a blend the robot stops "
        "at the goal. Every segment goal and blend window boundary is a returned point. A failing "
        "segment is 422 with `code`, `segment` and `s`; with `allow_partial` 200 with the program "
        "up to it (a collision: brought to rest before the contact along its path).\n\n"
        "PTP to a pose: the IK solution with `goal.configuration` (a label of /v1/robots/{name}/ik, "
        "e.g. `left-up-noflip`) nearest the current joints, else the nearest of all; a label the "
        "pose has no solution with is 422 `unreachable` naming the labels it has. LIN and CIRC "
        "keep the configuration label of their start (a change on the way is `branch_flip` at "
        "its `s`).\n\n"
        "PTP `profile` (`trapezoidal`, `quintic`, `jerk_limited`) times a PTP between stops (no "
        "blend at either end) rest to rest, synchronously (every joint on one normalized profile: "
        "the straight joint segment), the fastest within the joint limits times its scales (`jerk_limited`: the robot's jerk limits; none published: 422 "
        "`validation`). Inside a blend a profile has no meaning: the blended stretch is timed as "
        "one motion (time-optimal along the path, q'' continuous), and the profile is ignored "
        "with a warning. Without `profile` a PTP follows that common timing too.\n\n"
        "LIN/CIRC `speed_profile: s_curve` times its whole stretch between stops as one S-curve "
        "(continuous path acceleration, tool jerk within `max_linear_jerk`). LIN/CIRC `method: "
        "bounded_deviation` builds the segment's joint path from as few IK knots as keep it within "
        "its tolerance (segment `diagnostics.knot_count`).\n\n"
        "`diagnostics.peak_jerk` (and peak velocity/acceleration) are of the analytic q(t): exact "
        "for PTP profiles, over a dense grid (10 per timing knot interval) elsewhere."
    ),
)
def program_trajectory(
    body: ProgramRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    settings = request.app.state.settings
    robot = with_tool(registry.resolve(body.robot), body.tool)
    urdf = inline_urdf(body.robot)
    check = collision_check(robot, body.environment, urdf)
    task = task_from_request(body, robot, deadline, check)
    if body.samples is not None and body.samples > settings.max_points:
        raise TooLarge(
            f"samples exceeds the limit of {settings.max_points} points", field=("samples",)
        )
    started = time.perf_counter()
    result = plan_program(task)
    elapsed_ms = (time.perf_counter() - started) * 1e3
    check_finite(result.trajectory)
    if len(result.trajectory.times) > settings.max_points:
        raise TooLarge(
            f"the program has {len(result.trajectory.times)} points, over the limit of "
            f"{settings.max_points}; give a larger sample_period",
            field=("sample_period",),
        )
    unchecked = unchecked_warnings(robot, body.environment, urdf)
    return json_response(result_body(result, elapsed_ms, time_format, unchecked))
