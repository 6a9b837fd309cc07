"""The inputs of the velocity dampers of the DLS QP (``core.clearance``): for every checked pair
closer than an influence distance at one configuration, its distance, normal and point Jacobian
(closest points from coal, through pinocchio's ``computeDistances`` on the exact shapes)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pinocchio as pin

from robots.model import Robot


class CoalChecker(Protocol):
    """What ``damper_inputs`` reads of a ``CollisionChecker`` (its coal model and workspace)."""

    robot: Robot
    _coal: tuple[Any, ...] | None

    def coal_geometry(self) -> tuple[pin.GeometryModel, list[tuple[int, int]]]: ...


@dataclass(frozen=True)
class DamperInputs:
    """What ``core.clearance.velocity_damper_rows`` needs, for the pairs closer than an influence
    distance at one configuration (base frame).

    Attributes:
        pairs: ``(m,)`` indices into ``pair_names``.
        distances: ``(m,)`` [m].
        normals: ``(m, 3)`` unit, from the obstacle (or the second link) towards the robot point.
        point_jacobians: ``(m, 3, dof)`` linear Jacobian of the robot point (self pairs: of the
            first point minus the second), so that d' = n . (J qd).
    """

    pairs: np.ndarray
    distances: np.ndarray
    normals: np.ndarray
    point_jacobians: np.ndarray


def point_jacobian(
    model: pin.Model, data: pin.Data, gm: pin.GeometryModel, geom: int, p: np.ndarray
) -> np.ndarray:
    """``(3, nv)`` linear Jacobian (world frame) of the point ``p`` [m] fixed to geometry ``geom``."""
    joint = gm.geometryObjects[geom].parentJoint
    if joint == 0:
        return np.zeros((3, model.nv))
    J = pin.getJointJacobian(model, data, joint, pin.LOCAL_WORLD_ALIGNED)
    r = p - data.oMi[joint].translation
    skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return np.asarray(J[:3] - skew @ J[3:])


def damper_inputs(check: CoalChecker, q: np.ndarray, d_influence: float) -> DamperInputs:
    """Closest points (coal, through pinocchio's ``computeDistances``), normals and point Jacobians
    of every checked pair closer than ``d_influence`` [m] at ``q``: the rows of the velocity dampers
    of the DLS QP (``core.clearance``). One coal workspace per checker (a control loop calls this
    once per tick)."""
    model = check.robot.model
    q = np.asarray(q, dtype=float)
    if check._coal is None:
        gm, pairs = check.coal_geometry()
        index = {(cp.first, cp.second): k for k, cp in enumerate(gm.collisionPairs)}
        check._coal = (gm, pairs, index, pin.Data(model), pin.GeometryData(gm))
    gm, pairs, index, data, gdata = check._coal
    pin.computeDistances(model, data, gm, gdata, q)
    pin.computeJointJacobians(model, data, q)
    R = check.robot.chain.T_base_world[:3, :3]
    rows, dist, normals, jacs = [], [], [], []
    for p, (g1, g2) in enumerate(pairs):
        res = gdata.distanceResults[index[(g1, g2)]]
        d = float(res.min_distance)
        if d >= d_influence:
            continue
        p1, p2 = np.asarray(res.getNearestPoint1()), np.asarray(res.getNearestPoint2())
        gap = p1 - p2
        n = gap / np.linalg.norm(gap) if d > 1e-9 else -np.asarray(res.normal)
        J = point_jacobian(model, data, gm, g1, p1) - point_jacobian(model, data, gm, g2, p2)
        rows.append(p)
        dist.append(d)
        normals.append(R @ n)
        jacs.append(R @ J)
    m = len(rows)
    return DamperInputs(
        np.array(rows, dtype=int),
        np.array(dist),
        np.reshape(normals, (m, 3)),
        np.reshape(jacs, (m, 3, model.nv)),
    )
