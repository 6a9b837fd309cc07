"""The checker's shapes as a pinocchio ``GeometryModel`` (coal), and the closest pairs of one
configuration with their witness points (``POST /v1/distance``).

Robot shapes are placed in their parent joints' frames exactly as the numpy engine uses them
(capsules, spheres, boxes, cylinders); obstacles are fixed to the model's root (the world frame),
moved there from the base frame.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from robots.collision.entries import coal_shape
from robots.collision.shapes import Obstacle, RobotCollision


def _obstacle(o: Obstacle, T_world_base: np.ndarray) -> tuple[object, pin.SE3]:
    """A coal shape and its placement in the world frame."""
    if o.shape == "halfspace":
        n_w = T_world_base[:3, :3] @ np.array(o.normal, dtype=float)
        off = o.offset + float(n_w @ T_world_base[:3, 3])
        return coal.Halfspace(n_w, off), pin.SE3.Identity()
    shape = {
        "box": lambda: coal.Box(*o.size),
        "sphere": lambda: coal.Sphere(o.radius),
        "cylinder": lambda: coal.Cylinder(o.radius, o.length),
        "capsule": lambda: coal.Capsule(o.radius, o.length),
    }[o.shape]()
    T = T_world_base @ o.T_base_obstacle
    return shape, pin.SE3(T[:3, :3], T[:3, 3])


def build(
    geometry: RobotCollision,
    obstacles: tuple[Obstacle, ...],
    T_base_world: np.ndarray,
    obs_pairs: list[tuple[int, int]],
    self_pairs: list[tuple[int, int]],
) -> tuple[pin.GeometryModel, list[tuple[int, int]]]:
    """The ``GeometryModel`` with one collision pair per checked pair, and each checked pair's two
    geometry object indices (smaller first, as pinocchio orders ``collisionPairs``)."""
    gm = pin.GeometryModel()
    g = geometry
    T_world_base = np.linalg.inv(T_base_world)
    ids = []
    for i in range(len(g.links)):
        F = g.frames[i]
        obj = pin.GeometryObject(
            f"{g.links[i]}#{i}",
            int(g.joints[i]),
            pin.SE3(F[:3, :3], F[:3, 3]),
            coal_shape(int(g.kind[i]), g.dims[i]),
        )
        ids.append(gm.addGeometryObject(obj))
    oids = []
    for o in obstacles:
        shape, M = _obstacle(o, T_world_base)
        oids.append(gm.addGeometryObject(pin.GeometryObject(o.name, 0, M, shape)))
    pairs = [(ids[i], oids[k]) for i, k in obs_pairs] + [(ids[i], ids[j]) for i, j in self_pairs]
    pairs = [(min(p), max(p)) for p in pairs]
    for p in pairs:
        gm.addCollisionPair(pin.CollisionPair(*p))
    return gm, pairs


def closest_pairs(
    model: pin.Model,
    gm: pin.GeometryModel,
    pairs: list[tuple[int, int]],
    pair_names: list[tuple[str, str]],
    T_base_world: np.ndarray,
    q: np.ndarray,
    limit: int,
) -> list[tuple[tuple[str, str], float, np.ndarray, np.ndarray]]:
    """Per pair of names (the closest shape pair of each), closest first, at most ``limit``:
    ``(links, distance [m], point on the first, point on the second)``, points in the base frame."""
    names_of = {p: k for k, p in enumerate(pairs)}
    data, gdata = pin.Data(model), pin.GeometryData(gm)
    pin.computeDistances(model, data, gm, gdata, np.asarray(q, dtype=float))
    R, t = T_base_world[:3, :3], T_base_world[:3, 3]
    best: dict[tuple[str, str], tuple[float, np.ndarray, np.ndarray]] = {}
    for k, res in enumerate(gdata.distanceResults):
        cp = gm.collisionPairs[k]
        name = pair_names[names_of[(cp.first, cp.second)]]
        d = float(res.min_distance)
        if name not in best or d < best[name][0]:
            p1 = R @ np.asarray(res.getNearestPoint1()) + t
            p2 = R @ np.asarray(res.getNearestPoint2()) + t
            best[name] = (d, p1, p2)
    rows = sorted(((n, *v) for n, v in best.items()), key=lambda r: r[1])
    return rows[:limit]
