"""The ``<collision>`` primitives of a client URDF as capsules (spheres exact, boxes and cylinders
enclosed), and the links whose collision geometry is only meshes (not checked: a warning)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import defusedxml.ElementTree as DET
import numpy as np
import pinocchio as pin

from core.errors import InputError
from robots.geometry import Capsule


def _origin_rpy(el: ET.Element | None) -> pin.SE3:
    if el is None:
        return pin.SE3.Identity()
    xyz = [float(v) for v in (el.get("xyz") or "0 0 0").split()]
    rpy = [float(v) for v in (el.get("rpy") or "0 0 0").split()]
    if len(xyz) != 3 or len(rpy) != 3 or not all(map(math.isfinite, xyz + rpy)):
        raise InputError("a <collision> origin needs 3 finite xyz and rpy", field=("robot", "urdf"))
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))


def capsules_from_urdf(urdf: str) -> tuple[list[Capsule], list[str]]:
    """``<collision>`` primitives of a client URDF as capsules, and the mesh-only links.

    sphere: exact; cylinder (radius r, length l along z): the capsule of radius r over the axis
    shortened by r at each end when l > 2r, else the sphere around it; box: the capsule around its
    longest axis that contains it. Both enclose the shape (conservative). A primitive of zero size
    (a sphere of radius 0, a box of size 0 0 0, as real URDFs write for placeholder links) has no
    volume and is skipped; a box flat in one or two axes keeps its capsule.
    """
    root = DET.fromstring(urdf, forbid_dtd=True, forbid_entities=True)  # text, as the screen
    capsules: list[Capsule] = []
    mesh_only: list[str] = []
    for link in root.findall("link"):
        name = link.get("name") or ""
        found_primitive = found_mesh = False
        for col in link.findall("collision"):
            geo = col.find("geometry")
            if geo is None:
                continue
            M = _origin_rpy(col.find("origin"))
            for shape in geo:
                cap = _shape_capsule(shape)
                if cap is None:
                    found_mesh = found_mesh or shape.tag == "mesh"
                    continue
                ra, rb, r = cap
                if r == 0.0:
                    continue  # zero size: no volume to check (never a zero-radius capsule)
                capsules.append(Capsule(name, tuple(M.act(ra)), tuple(M.act(rb)), r))  # type: ignore[arg-type]
                found_primitive = True
        if found_mesh and not found_primitive:
            mesh_only.append(name)
    return capsules, mesh_only


def _size(el: ET.Element, attr: str) -> float:
    try:
        v = float(el.get(attr, "nan"))
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and 0 <= v <= 1e3):
        raise InputError(
            f"a <collision> {el.tag} needs {attr} in [0, 1000] m", field=("robot", "urdf")
        )
    return v


def _shape_capsule(shape: ET.Element) -> tuple[np.ndarray, np.ndarray, float] | None:
    o = np.zeros(3)
    if shape.tag == "sphere":
        return o, o, _size(shape, "radius")
    if shape.tag == "cylinder":
        r, h = _size(shape, "radius"), _size(shape, "length")
        if h > 2 * r:
            e = np.array([0.0, 0.0, h / 2 - r])
            return -e, e, math.hypot(r, r)  # covers the rim: distance sqrt(r^2 + r^2) from the end
        return o, o, math.hypot(r, h / 2)
    if shape.tag == "box":
        try:
            size = np.array([float(v) for v in (shape.get("size") or "").split()])
        except ValueError:
            size = np.array([])
        if size.shape != (3,) or not np.all(np.isfinite(size) & (size >= 0) & (size <= 1e3)):
            raise InputError(
                "a <collision> box needs 3 sizes in [0, 1000] m", field=("robot", "urdf")
            )
        k = int(np.argmax(size))
        others = np.delete(size, k) / 2
        r = float(np.hypot(*others))
        e = np.zeros(3)
        e[k] = max(size[k] / 2 - r, 0.0)
        r = max(r, float(np.linalg.norm(size / 2))) if e[k] == 0 else math.hypot(r, r)
        return -e, e, r
    return None
