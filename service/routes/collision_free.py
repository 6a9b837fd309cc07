"""POST /v1/trajectories/collision_free: a joint motion that plans around obstacles.

Thin route: schema -> ``MotionTask`` and the robot's clearance (``service.convert.collision_free``)
-> ``core.motion.plan.plan_motion`` (start and goal checked before any search, the usual
continuous check of the returned points after it, ``core.collisions``) -> response. Plain ``def``:
planning is CPU-bound, so FastAPI runs it in its thread pool.
"""

from __future__ import annotations

import time

from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from core.budget import Deadline
from core.motion.clearance import Unobstructed
from core.motion.plan import plan_motion
from robots.validity import GroupedClearance
from service import deps
from service.convert import collision_free as convert
from service.convert.environment import collision_check, inline_urdf, unchecked_warnings
from service.convert.robot import resolve_robot
from service.schemas.collision_free import CollisionFreeRequest
from service.schemas.common import (
    TIME_FORMAT_QUERY,
    TimeFormat,
    TrajectoryResponse,
    trajectory_responses,
)

router = APIRouter(prefix="/v1/trajectories", tags=["collision_free"])


@router.post(
    "/collision_free",
    responses=trajectory_responses(TrajectoryResponse),
    summary="Collision-free joint motion: plans around the environment's obstacles",
    description=(
        "A joint motion from `start` to `goal` (joints, or a pose: its IK solutions, clear ones "
        "nearest the start first) that keeps `environment.clearance` from every obstacle and its "
        "links apart at every instant. The direct segment when it is clear, else RRT-Connect "
        "(OMPL), shortened and smoothed; every segment certified by the motion bound (no "
        "resolution), then timed. Deterministic per `seed`. 422 `collision` (`at`: start or "
        "goal), `unreachable` (every IK solution collides) or `no_path_found`."
    ),
)
def collision_free_trajectory(
    body: CollisionFreeRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    started = time.perf_counter()
    settings = request.app.state.settings
    robot = resolve_robot(body.robot, body.tool)
    assert robot is not None  # the schema requires one
    urdf = inline_urdf(body.robot)
    task = convert.motion_task(body, robot, deadline, settings.max_points, settings.time_budget_s)
    check = collision_check(robot, body.environment, urdf)
    grouped = None if check is None else GroupedClearance(check)
    result = plan_motion(task, grouped or Unobstructed(robot.dof), check=check)
    warnings = unchecked_warnings(robot, body.environment, urdf)
    return convert.response(result, warnings, started, time_format)
