"""POST /v1/robots/{name}/distance and POST /v1/distance: clearances of one configuration.

Thin routes: schema -> ``robots.collision`` (coal through pinocchio's ``GeometryModel``) -> the closest
pairs (per pair of names, closest first, at most 20) with their witness points in the base frame.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from fastapi import APIRouter
from pydantic import Field
from starlette.responses import Response

from core.errors import InputError
from robots import registry
from robots.collision import robot_setup
from service.convert.environment import collision_check, inline_urdf
from service.encoding import json_response
from service.schemas.common import PROBLEM_RESPONSES, JointPositions, RobotRef, StrictModel
from service.schemas.environment import Environment

router = APIRouter(prefix="/v1", tags=["collision"])
MAX_PAIRS = 20


class DistanceRequest(StrictModel):
    positions: JointPositions = Field(description="Joint positions [rad or m], one per joint.")
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


def _distance(robot_ref: Any, body: DistanceRequest) -> Response:
    robot = registry.resolve(robot_ref)
    q = np.asarray(body.positions, dtype=float)
    if q.shape != (robot.dof,):
        raise InputError(f"positions needs {robot.dof} values", field=("positions",))
    check = collision_check(robot, body.environment, inline_urdf(robot_ref))
    rows = [] if check is None else check.closest_pairs(q, MAX_PAIRS)
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
def robot_distance(name: str, body: DistanceRequest) -> Response:
    return _distance(name, body)


@router.post(
    "/distance",
    responses=RESPONSES,
    summary="Distances at one configuration for a robot given in the body (name or inline URDF)",
)
def distance(body: InlineDistanceRequest) -> Response:
    return _distance(body.robot, body)


def collision_description(robot_ref: Any) -> dict[str, Any]:
    """``collision_geometry`` and ``allowed_self_collisions`` of a robot, for its GET description
    (the robots route belongs to another team: its owner adds these two keys)."""
    robot = registry.resolve(robot_ref)
    geometry, allowed = robot_setup(robot, inline_urdf(robot_ref))
    capsules = [
        {
            "link": link,
            "type": "capsule",
            "a": geometry.a[i].tolist(),
            "b": geometry.b[i].tolist(),
            "radius": float(geometry.radius[i]),
            "frame": "joint",
            "joint": robot.model.names[int(geometry.joints[i])],
        }
        for i, link in enumerate(geometry.links)
    ]
    return {
        "collision_geometry": capsules,
        "allowed_self_collisions": sorted(sorted(p) for p in allowed),
    }
