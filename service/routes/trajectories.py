"""/v1/trajectories/joint and /v1/trajectories/spline: joint-space plans.

Thin routes: schema -> numpy (``service.convert.joint``) -> one core call -> response
(``service.encoding``).
Planning is CPU-bound: ``service.dispatch`` runs it in the thread pool, or on the event loop when
it is tiny joint math (no robot, a small known sample count).
"""

from __future__ import annotations

import time

from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from core.budget import Deadline
from core.joint.point_to_point import plan_joint
from core.joint.splines import plan_spline
from service import deps, dispatch
from service.convert import joint as convert
from service.convert.environment import clearance_diagnostics, joint_request_check
from service.schemas.common import (
    TIME_FORMAT_QUERY,
    TimeFormat,
    TrajectoryResponse,
    trajectory_responses,
)
from service.schemas.trajectories import JointTrajectoryRequest, SplineRequest

router = APIRouter(prefix="/v1/trajectories", tags=["trajectories"])

RESPONSES = trajectory_responses(TrajectoryResponse)


@router.post(
    "/joint",
    responses=RESPONSES,
    summary="Point-to-point joint move: linear, cubic, quintic, trapezoidal or jerk_limited",
)
async def joint_trajectory(
    body: JointTrajectoryRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    started = time.perf_counter()

    def respond() -> Response:
        inputs = convert.joint_inputs(body)
        check, unchecked = joint_request_check(inputs.robot, body.robot, body.environment)
        plan = plan_joint(
            body.profile,
            inputs.motion,
            inputs.limits,
            duration=body.duration,
            sample_period=body.sample_period,
            samples=body.samples,
            max_points=request.app.state.settings.max_points,
            joint_names=inputs.joint_names,
            deadline=deadline,
            effort=inputs.effort,
            collision_check=check,
            dynamics=inputs.dynamics,
            gravity=inputs.gravity,
        )
        return convert.trajectory_response(
            plan.trajectory,
            body.profile,
            (*plan.warnings, *unchecked),
            started,
            time_format,
            **convert.effort_diagnostics(plan),
            **clearance_diagnostics(plan.clearance, unchecked),
        )

    return await dispatch.run_plan(
        respond, dispatch.answer_numbers(body, len(body.start.positions))
    )


@router.post(
    "/spline",
    responses=RESPONSES,
    summary="C2 cubic spline through waypoints (clamped, natural, not-a-knot)",
)
async def spline_trajectory(
    body: SplineRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    started = time.perf_counter()

    def respond() -> Response:
        inputs = convert.spline_inputs(body)
        check, unchecked = joint_request_check(inputs.robot, body.robot, body.environment)
        settings = request.app.state.settings
        plan = plan_spline(
            inputs.waypoints,
            times=inputs.times,
            boundary=body.boundary,
            start_velocity=inputs.start_velocity,
            goal_velocity=inputs.goal_velocity,
            limits=inputs.limits,
            sample_period=body.sample_period,
            samples=body.samples,
            max_points=settings.max_points,
            joint_names=inputs.joint_names,
            deadline=deadline,
            effort=inputs.effort,
            collision_check=check,
            dynamics=inputs.dynamics,
            gravity=inputs.gravity,
        )
        return convert.trajectory_response(
            plan.trajectory,
            "spline",
            (*plan.warnings, *unchecked),
            started,
            time_format,
            boundary=body.boundary,
            knot_times=plan.knot_times,
            **convert.effort_diagnostics(plan),
            **clearance_diagnostics(plan.clearance, unchecked),
        )

    return await dispatch.run_plan(
        respond, dispatch.answer_numbers(body, len(body.waypoints[0]) if body.waypoints else 0)
    )
