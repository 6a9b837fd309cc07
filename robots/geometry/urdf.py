"""The ``<collision>`` primitives of a client URDF as link shapes, and the links whose collision
geometry is only meshes (not checked: a warning).

Spheres become capsules of length 0 (exact); boxes and cylinders stay boxes and cylinders (exact,
checked with their own distance functions and coal). Every number goes through the screen's one
attribute parser (``robots.urdf_screen.floats``): a malformed or non-finite value is ``InvalidURDF``
naming the link and the attribute, never a 500.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import defusedxml.ElementTree as DET
import numpy as np
import pinocchio as pin

from core.errors import InvalidURDF
from robots.geometry import Box, Capsule, Cylinder, LinkShape
from robots.urdf_screen import FIELD, MAX_COORDINATE, floats

MAX_SIZE = 100.0
"""[m] Largest size of a ``<collision>`` primitive (radius, length, box edge): the bound of an
obstacle's sizes, so that ``collision_geometry`` reports every shape in the obstacles' form."""
MIN_EXTENT = 1e-6
"""[m] A box edge or cylinder length of 0 (a flat primitive that still has an area, as URDFs write
for plates) is checked as this thin."""


def _origin(el: ET.Element | None, where: str) -> np.ndarray:
    """``T_link_shape`` (4, 4) of a ``<collision>``'s ``<origin>`` (identity when absent)."""
    if el is None:
        return np.eye(4)
    xyz = floats(el.get("xyz"), 3, f"{where} origin xyz", (0.0,) * 3)
    rpy = floats(el.get("rpy"), 3, f"{where} origin rpy", (0.0,) * 3)
    if max(abs(v) for v in xyz + rpy) > MAX_COORDINATE:
        raise InvalidURDF(f"{where} origin is beyond 1e4 (m or rad)", field=FIELD)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = pin.rpy.rpyToMatrix(*rpy), xyz
    return T


def _size(el: ET.Element, attr: str, where: str) -> float:
    (v,) = floats(el.get(attr), 1, f"{where} {el.tag} {attr}", (math.nan,))
    if not (math.isfinite(v) and 0 <= v <= MAX_SIZE):
        raise InvalidURDF(f"{where} {el.tag} {attr} must be in [0, 100] m", field=FIELD)
    return v


def _shape(shape: ET.Element, link: str, T: np.ndarray, where: str) -> LinkShape | None:
    """The link shape of one ``<geometry>`` child; None for a mesh, an unknown tag and a primitive
    of zero size (no volume: a sphere of radius 0, a box of size 0 0 0, a cylinder of radius 0)."""
    if shape.tag == "sphere":
        r = _size(shape, "radius", where)
        c = tuple(float(v) for v in T[:3, 3])
        return Capsule(link, c, c, r) if r > 0 else None  # type: ignore[arg-type]
    if shape.tag == "cylinder":
        r, length = _size(shape, "radius", where), _size(shape, "length", where)
        return Cylinder(link, r, max(length, MIN_EXTENT), T) if r > 0 else None
    if shape.tag == "box":
        size = floats(shape.get("size"), 3, f"{where} box size", (math.nan,) * 3)
        if not all(math.isfinite(v) and 0 <= v <= MAX_SIZE for v in size):
            raise InvalidURDF(f"{where} box size must be 3 numbers in [0, 100] m", field=FIELD)
        if max(size) == 0:
            return None
        return Box(link, tuple(max(v, MIN_EXTENT) for v in size), T)  # type: ignore[arg-type]
    return None


def shapes_from_urdf(urdf: str) -> tuple[list[LinkShape], list[str]]:
    """``<collision>`` primitives of a client URDF as link shapes (link frames), and the mesh-only
    links. A primitive of zero size is skipped (placeholders in Kinova's and Atlas's URDFs); a flat
    box or a disc keeps ``MIN_EXTENT`` of thickness."""
    root = DET.fromstring(urdf, forbid_dtd=True, forbid_entities=True)  # text, as the screen
    shapes: list[LinkShape] = []
    mesh_only: list[str] = []
    for link in root.findall("link"):
        name = link.get("name") or ""
        where = f"link '{name if len(name) <= 64 else name[:61] + '...'}' <collision>"
        found_primitive = found_mesh = False
        for col in link.findall("collision"):
            geo = col.find("geometry")
            if geo is None:
                continue
            T = _origin(col.find("origin"), where)
            for element in geo:
                shape = _shape(element, name, T, where)
                found_mesh = found_mesh or element.tag == "mesh"
                if shape is not None:
                    shapes.append(shape)
                    found_primitive = True
                elif element.tag in ("sphere", "box", "cylinder"):
                    found_primitive = True  # zero size: nothing to check, nothing unchecked
        if found_mesh and not found_primitive:
            mesh_only.append(name)
    return shapes, mesh_only


def enclosing_capsule(shape: LinkShape) -> tuple[np.ndarray, np.ndarray, float]:
    """A capsule ``(a, b, radius)`` (link frame) containing ``shape``: the capsule itself, or for a
    box the capsule about its longest axis through its corners, for a cylinder the capsule of radius
    r sqrt(2) over its axis shortened by r at each end (the sphere about it when short). Used only
    for cheap lower bounds of distances (a pair farther apart than its enclosing capsules needs no
    exact distance)."""
    if isinstance(shape, Capsule):
        return np.array(shape.a, dtype=float), np.array(shape.b, dtype=float), shape.radius
    T = shape.T_link_shape
    e = np.zeros(3)
    if isinstance(shape, Cylinder):
        r, h = shape.radius, shape.length / 2
        if h > r:
            e[2], radius = h - r, math.hypot(r, r)
        else:
            radius = math.hypot(r, h)
    else:
        half = np.array(shape.size) / 2
        k = int(np.argmax(half))
        side = float(np.hypot(*np.delete(half, k)))
        e[k] = max(half[k] - side, 0.0)
        radius = math.hypot(side, side) if e[k] > 0 else float(np.linalg.norm(half))
    R, t = T[:3, :3], T[:3, 3]
    return t - R @ e, t + R @ e, radius
