"""POST /v1/robots/{name}/distance and POST /v1/distance: clearances of one configuration.

Thin routes: schema -> ``robots.collision`` (coal through pinocchio's ``GeometryModel``) -> the closest
pairs (per pair of names, closest first, at most 20) with their witness points in the base frame.
The positions pass the entry checks of every planning route (422 ``joint_limit`` outside the
limits) and the request has the planning routes' deadline (422 ``time_budget_exceeded``).
"""

from __future__ import annotations

import math
from typing import Any

from fastapi import APIRouter, Depends
from pydantic import Field
from starlette.responses import Response

from core.budget import Deadline
from robots import registry
from robots.collision import link_shapes, robot_setup
from service import deps
from service.convert.environment import collision_check, inline_urdf
from service.convert.robot import robot_positions, with_tool
from service.encoding import json_response
from service.schemas.common import (
    PROBLEM_RESPONSES,
    TOOL_FIELD,
    JointPositions,
    RobotRef,
    StrictModel,
    Tool,
)
from service.schemas.environment import Environment

router = APIRouter(prefix="/v1", tags=["collision"])
MAX_PAIRS = 20


class DistanceRequest(StrictModel):
    positions: JointPositions = Field(description="Joint positions [rad or m], one per joint.")
    tool: Tool | None = TOOL_FIELD
    environment: Environment | None = Field(default=None, description="Obstacles and options.")


class InlineDistanceRequest(DistanceRequest):
    robot: RobotRef


class PairDistance(StrictModel):
    links: list[str]
    distance: float = Field(description="[m], negative: penetration.")
    points: list[list[float]] = Field(description="Closest points [m] in the base frame.")


class DistanceResponse(StrictModel):
    min_distance: float | None = Field(description="[m]; null when no pair is checked.")
    pairs: list[PairDistance]


RESPONSES: dict[int | str, dict[str, Any]] = {200: {"model": DistanceResponse}, **PROBLEM_RESPONSES}


def _distance(robot_ref: Any, body: DistanceRequest, deadline: Deadline) -> Response:
    """The closest pairs at ``body.positions``, after the entry checks of every planning route
    (``robot_positions``: one per joint, inside the limits) and within the request's deadline,
    checked between the stages (the robot, its checker, the distances)."""
    robot = with_tool(registry.resolve(robot_ref), body.tool)  # checked; no geometry of its own
    q = robot_positions(robot, body.positions, ("positions",))
    deadline.check("distance: loading the robot")
    check = collision_check(robot, body.environment, inline_urdf(robot_ref))
    deadline.check("distance: building the collision model")
    rows = [] if check is None else check.closest_pairs(q, MAX_PAIRS)
    deadline.check("distance: computing the distances")
    pairs = [
        {"links": list(n), "distance": d, "points": [p1.tolist(), p2.tolist()]}
        for n, d, p1, p2 in rows
        if math.isfinite(d)
    ]
    return json_response({"min_distance": pairs[0]["distance"] if pairs else None, "pairs": pairs})


@router.post(
    "/robots/{name}/distance",
    responses=RESPONSES,
    summary="Distances between a registered robot's links and the obstacles at one configuration",
)
def robot_distance(
    name: str, body: DistanceRequest, deadline: Deadline = Depends(deps.request_deadline)
) -> Response:
    return _distance(name, body, deadline)


@router.post(
    "/distance",
    responses=RESPONSES,
    summary="Distances at one configuration for a robot given in the body (name or inline URDF)",
)
def distance(
    body: InlineDistanceRequest, deadline: Deadline = Depends(deps.request_deadline)
) -> Response:
    return _distance(body.robot, body, deadline)


def collision_description(robot_ref: Any) -> dict[str, Any]:
    """``collision_geometry`` and ``allowed_self_collisions`` of a robot, as in its description:
    each shape as the check uses it (``robots.collision.link_shapes``), in its link's frame."""
    robot = registry.resolve(robot_ref)
    geometry, allowed = robot_setup(robot, inline_urdf(robot_ref))
    shapes = [
        {"link": link, "shape": shape, "origin": T.tolist()}
        for link, shape, T in link_shapes(robot, geometry)
    ]
    return {
        "collision_geometry": shapes,
        "allowed_self_collisions": sorted(sorted(p) for p in allowed),
    }
