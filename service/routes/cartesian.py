"""POST /v1/trajectories/cartesian: the tool on the straight line from FK(start) to the goal pose.

Thin route: schema -> ``CartesianTask`` (``service.convert.cartesian``, the request's collision
object built once) -> ``core.cartesian.plan.plan`` (plan, check, stop before a contact) -> response. Every method of API.md is accepted and passed on to the core's dispatch. Plain ``def``:
planning is CPU-bound, so FastAPI runs it in its thread pool.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from core.budget import Deadline
from robots import registry
from service import deps
from service.convert import cartesian as convert
from service.convert.environment import inline_urdf, unchecked_warnings
from service.convert.robot import with_tool
from service.encoding import json_response
from service.schemas.cartesian import CartesianRequest, CartesianResponse
from service.schemas.common import TIME_FORMAT_QUERY, TimeFormat, trajectory_responses

router = APIRouter(prefix="/v1/trajectories", tags=["cartesian"])

RESPONSES = trajectory_responses(CartesianResponse)


@router.post(
    "/cartesian",
    responses=RESPONSES,
    summary="Straight-line Cartesian motion: sampled IK, bounded deviation, resolved rate",
    description=(
        "The tool moves on the straight line from FK(start.positions) to the goal pose: position by "
        "linear interpolation, orientation by slerp on the shorter arc (position_xy robots: x and y "
        "only). s(t) follows a quintic over `duration`, or the shortest profile under "
        "`max_linear_speed`/`max_angular_speed`, slowed down where joint limits need it (a "
        "warning says where). A plan that cannot be completed is 422 with `code` (unreachable, "
        "joint_limit, branch_flip, singularity, joint_rate_limit, ...) and `s`; with "
        "`allow_partial` it is 200 with the planned prefix, `fraction` < 1 and "
        "`diagnostics.failure`."
    ),
)
def cartesian_trajectory(
    body: CartesianRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    settings = request.app.state.settings
    robot = with_tool(registry.resolve(body.robot), body.tool)
    task = convert.task_from_spec(body, robot, deadline, settings.max_points)
    result, elapsed_ms = convert.run(task, body.method, settings.max_points)
    unchecked = unchecked_warnings(robot, body.environment, inline_urdf(body.robot))
    doc = convert.result_body(result, body.method, elapsed_ms, time_format, unchecked)
    return json_response(doc)
