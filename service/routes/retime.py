"""/v1/trajectories/retime: a geometric joint path through waypoints, timed at the optimum.

Thin route: schema -> numpy (``service.convert.retime``) -> one core call
(``core.joint.retime.plan_retime``) -> the continuous collision check -> response.
"""

from __future__ import annotations

import time

from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from core.budget import Deadline
from core.joint.retime import plan_retime
from service import deps, dispatch
from service.convert import joint as convert
from service.convert.environment import clearance_diagnostics, joint_request_check
from service.convert.retime import retime_diagnostics, retime_inputs
from service.schemas.common import (
    TIME_FORMAT_QUERY,
    TimeFormat,
    TrajectoryResponse,
    trajectory_responses,
)
from service.schemas.retime import RetimeRequest

router = APIRouter(prefix="/v1/trajectories", tags=["trajectories"])


@router.post(
    "/retime",
    responses=trajectory_responses(TrajectoryResponse),
    summary="Time-optimal timing of a path through waypoints (spline or blended corners)",
)
async def retime_trajectory(
    body: RetimeRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    started = time.perf_counter()

    def respond() -> Response:
        inputs = retime_inputs(body)
        check, unchecked = joint_request_check(inputs.robot, body.robot, body.environment)
        plan = plan_retime(
            inputs.waypoints,
            inputs.limits,
            path=body.path,
            max_deviation=inputs.max_deviation,
            tool=inputs.tool,
            effort=inputs.effort,
            dynamics=inputs.dynamics,
            gravity=inputs.gravity,
            sample_period=body.sample_period,
            samples=body.samples,
            max_points=request.app.state.settings.max_points,
            joint_names=inputs.joint_names,
            deadline=deadline,
            collision_check=check,
        )
        return convert.trajectory_response(
            plan.trajectory,
            body.path,
            unchecked,
            started,
            time_format,
            **retime_diagnostics(plan),
            **clearance_diagnostics(plan.clearance, unchecked),
        )

    return await dispatch.run_plan(respond, None)
