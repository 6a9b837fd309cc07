"""A robot's collision shapes attached to its pinocchio joints, and back in link frames for its
description (``collision_geometry``).

The shipped robots' capsules come from ``robots.geometry``; an inline URDF's ``<collision>``
spheres, boxes and cylinders from ``robots.geometry.urdf`` (exact shapes; mesh-only links are listed
in ``unchecked_links``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from core.errors import TooLarge
from robots.collision.shapes import BOX, CAPSULE, CYLINDER, RobotCollision, capsule_frame
from robots.geometry import ROBOT_GEOMETRY, Box, Cylinder, LinkShape
from robots.geometry.urdf import enclosing_capsule, shapes_from_urdf
from robots.model import Robot

MAX_CAPSULES = 128
"""Most collision primitives of an inline URDF (its self pairs grow with the square: building the
allowed pairs took 0.4 s for 92 primitives, 1.0 s for 184, 2.3 s for 276, once per robot). 128 takes
real robots with two arms and hands (franka_description's dual Panda has 89; 64 refused it)."""


def link_frame_id(model: pin.Model, link: str) -> int:
    """The frame of link ``link``, looked up by kind: a joint may share a link's name (Baxter's
    ``right_hand``), and pinocchio's untyped look-up then fails ("Several frames match")."""
    return int(model.getFrameId(link, pin.FrameType.BODY))


def _in_link(shape: LinkShape) -> tuple[int, np.ndarray, np.ndarray]:
    """``(kind, T_link_shape (4, 4), dims (3,))`` of a link shape (see ``RobotCollision``)."""
    if isinstance(shape, Box):
        return BOX, shape.T_link_shape, np.array(shape.size, dtype=float) / 2
    if isinstance(shape, Cylinder):
        return CYLINDER, shape.T_link_shape, np.array([shape.radius, shape.length / 2, 0.0])
    T, half = capsule_frame(np.array(shape.a, dtype=float), np.array(shape.b, dtype=float))
    return CAPSULE, T, np.array([shape.radius, half, 0.0])


def attach(model: pin.Model, shapes: Sequence[LinkShape]) -> RobotCollision:
    """Link shapes -> shapes in their parent joint frames (shapes of links the model does not hold,
    off the base -> tip chain, are dropped)."""
    links, joints, kinds, a, b, r, frames, dims = [], [], [], [], [], [], [], []
    for shape in shapes:
        if not model.existFrame(shape.link, pin.FrameType.BODY):
            continue
        frame = model.frames[link_frame_id(model, shape.link)]
        M = frame.placement.homogeneous
        kind, T, d = _in_link(shape)
        ca, cb, cr = enclosing_capsule(shape)
        links.append(shape.link)
        joints.append(frame.parentJoint)
        kinds.append(kind)
        a.append(M[:3, :3] @ ca + M[:3, 3])
        b.append(M[:3, :3] @ cb + M[:3, 3])
        r.append(cr)
        frames.append(M @ T)
        dims.append(d)
    return RobotCollision(
        tuple(links),
        np.array(joints, dtype=int),
        np.array(kinds, dtype=int),
        np.reshape(a, (-1, 3)),
        np.reshape(b, (-1, 3)),
        np.array(r, dtype=float),
        np.reshape(frames, (-1, 4, 4)),
        np.reshape(dims, (-1, 3)),
    )


def robot_collision(robot: Robot, urdf: str | None = None) -> RobotCollision:
    """The shapes of a shipped robot (``robots.geometry``) or of an inline URDF's primitives."""
    if urdf is None:
        geometry = ROBOT_GEOMETRY.get(robot.name)
        return attach(robot.model, geometry.capsules if geometry else ())
    shapes, mesh_only = shapes_from_urdf(urdf)
    rc = attach(robot.model, shapes)
    if len(rc.links) > MAX_CAPSULES:
        raise TooLarge(
            f"the URDF has {len(rc.links)} collision primitives on the robot; at most "
            f"{MAX_CAPSULES} are checked",
            field=("robot", "urdf"),
            extra={"limit_primitives": MAX_CAPSULES},
        )
    held = tuple(m for m in mesh_only if robot.model.existFrame(m, pin.FrameType.BODY))
    return RobotCollision(
        rc.links, rc.joints, rc.kind, rc.a, rc.b, rc.radius, rc.frames, rc.dims, held
    )


def link_shapes(
    robot: Robot, geometry: RobotCollision
) -> list[tuple[str, dict[str, Any], np.ndarray]]:
    """Each shape as used by the check: ``(link, shape, T_link_shape (4, 4))`` with ``shape`` in
    the form of an obstacle's (``{"type": "capsule", "radius", "length"}``, ``sphere``, ``box`` with
    full edge lengths ``size``, ``cylinder``) and its centre and axes in the frame of ``link`` (the
    inverse of ``attach``): the form of ``collision_geometry`` in a robot's description."""
    model = robot.model
    rows = []
    for i, link in enumerate(geometry.links):
        M_inv = model.frames[link_frame_id(model, link)].placement.inverse().homogeneous
        T = M_inv @ geometry.frames[i]
        d = geometry.dims[i]
        if geometry.kind[i] == BOX:
            shape: dict[str, Any] = {"type": "box", "size": (2 * d).tolist()}
        elif geometry.kind[i] == CYLINDER:
            shape = {"type": "cylinder", "radius": float(d[0]), "length": float(2 * d[1])}
        elif d[1] > 0:
            shape = {"type": "capsule", "radius": float(d[0]), "length": float(2 * d[1])}
        else:
            shape = {"type": "sphere", "radius": float(d[0])}
        rows.append((link, shape, T))
    return rows
