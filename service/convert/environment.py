"""A request's ``environment`` -> the one collision object of the request (a ``Clearance``), and
a checked motion's ``ClearanceReport`` -> the diagnostics keys.

The service builds the collision object once per request (``collision_check``) and hands it to
core in the task; core checks every answer with it (``core.collisions``) and, for the methods
that avoid obstacles, plans around it. Without ``environment``, a robot with collision geometry is
still checked for self-collision. What the check cannot see (mesh-only links; obstacles for a robot
without collision geometry) is a warning (``unchecked_warnings``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from core.collisions import ClearanceReport
from core.errors import InputError
from robots.collision import CollisionChecker, Obstacle, robot_setup
from robots.model import Robot
from service.memo import collision_key, shared
from service.schemas.common import InlineRobot
from service.schemas.environment import Environment, Halfspace

Field = tuple[str | int, ...]


def inline_urdf(robot_ref: object) -> str | None:
    """The URDF text of an inline robot reference, None for a registered name."""
    if isinstance(robot_ref, InlineRobot):
        return robot_ref.urdf
    if isinstance(robot_ref, dict):
        urdf = robot_ref.get("urdf")
        return urdf if isinstance(urdf, str) else None
    return None


def obstacles(env: Environment) -> list[Obstacle]:
    """The request's obstacles as ``robots.collision.Obstacle`` (base frame)."""
    out = []
    for o in env.obstacles:
        s = o.shape
        if isinstance(s, Halfspace):
            normal = (float(s.normal[0]), float(s.normal[1]), float(s.normal[2]))
            out.append(Obstacle(o.name, "halfspace", normal=normal, offset=s.offset))
            continue
        T = np.eye(4) if o.pose is None else o.pose.as_matrix()
        out.append(
            Obstacle(
                o.name,
                s.type,
                size=tuple(getattr(s, "size", ())),
                radius=float(getattr(s, "radius", 0.0)),
                length=float(getattr(s, "length", 0.0)),
                T_base_obstacle=T,
            )
        )
    return out


@shared("collision_model", collision_key)
def collision_check(
    robot: Robot,
    env: Environment | None,
    urdf: str | None = None,
    field: Field = ("environment",),
) -> CollisionChecker | None:
    """The request's collision object, or None when there is nothing to check.

    Raises ``InputError`` at the field for an obstacle named like a link and for names in
    ``allowed_collisions`` that are neither links nor obstacles. A kinematic model that is not a
    ``robots.model.Robot`` (a test's toy) has no collision geometry: None.
    """
    if not isinstance(robot, Robot):
        return None
    geometry, allowed_self = robot_setup(robot, urdf)
    env = env or Environment()
    links = set(robot.frame_names())
    for i, o in enumerate(env.obstacles):
        if o.name in links:
            raise InputError(
                "an obstacle may not have the name of one of the robot's links",
                field=(*field, "obstacles", i, "name"),
            )
    names = links | {o.name for o in env.obstacles}
    for i, pair in enumerate(env.allowed_collisions):
        for j, name in enumerate(pair):
            if name not in names:
                raise InputError(
                    "allowed_collisions names a link or obstacle that does not exist",
                    field=(*field, "allowed_collisions", i, j),
                    extra={"links": sorted(links)},
                )
    if len(geometry.links) == 0:
        return None
    check = CollisionChecker(
        robot,
        geometry,
        obstacles(env),
        clearance=env.clearance,
        self_collision=env.self_collision,
        allowed=[(a, b) for a, b in env.allowed_collisions],
        allowed_self=allowed_self,
    )
    return check if check.n_pairs else None


def unchecked_warnings(robot: Robot, env: Environment | None, urdf: str | None) -> tuple[str, ...]:
    """Warnings for what the collision check cannot see: each link whose collision geometry is
    mesh-only, and the obstacles of ``env`` when the robot has no collision geometry at all."""
    if not isinstance(robot, Robot):
        return ()
    geometry, _ = robot_setup(robot, urdf)
    out = [
        f"link {n} has only mesh collision geometry: it is not checked"
        for n in geometry.unchecked_links
    ]
    if len(geometry.links) == 0 and env is not None and env.obstacles:
        out.append(
            "the robot has no collision geometry (no <collision> box, sphere or cylinder): the "
            "environment's obstacles are not checked"
        )
    return tuple(out)


def clearance_diagnostics(
    report: ClearanceReport | None, warnings: tuple[str, ...] = ()
) -> dict[str, Any]:
    """``min_clearance`` [m], ``closest`` (pair names, time [s]), ``clearance_profile`` and, when
    some links are not checked, ``collision_warnings``; empty when nothing was checked."""
    if report is None:
        return {}
    out: dict[str, Any] = {
        "min_clearance": float(report.min_clearance),
        "closest": None
        if report.closest is None
        else {"links": list(report.closest[0]), "time_from_start": float(report.closest[1])},
        "clearance_profile": {
            "time_from_start": report.profile_times.tolist(),
            "value": report.profile_values.tolist(),
        },
    }
    if warnings:
        out["collision_warnings"] = list(warnings)
    return out


def joint_request_check(
    robot: Robot | None, robot_ref: object, env: Environment | None
) -> tuple[CollisionChecker | None, tuple[str, ...]]:
    """The collision object and the unchecked-geometry warnings of a joint-space request
    (``robot`` resolved from ``robot_ref``): nothing to check without a robot; an environment
    without a robot is 422 at the field."""
    if robot is None:
        if env is not None:
            raise InputError("an environment needs a robot", field=("environment",))
        return None, ()
    urdf = inline_urdf(robot_ref)
    return collision_check(robot, env, urdf), unchecked_warnings(robot, env, urdf)
