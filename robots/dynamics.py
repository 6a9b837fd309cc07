"""Rigid-body inverse dynamics of a robot on pinocchio's RNEA: the ``core.kinematics.Dynamics``
Protocol.

``tau = M(q) q'' + C(q, q') q' + g(q)`` (plus the rotor inertia ``model.armature`` times q'', which
pinocchio's RNEA adds) for many samples at once; no friction. Along a path q(s) the torque is affine
in (s'', s'^2): ``tau = a s'' + b s'^2 + c`` with three RNEA calls per sample, ``a = RNEA(q, 0,
q_s)`` and ``b = RNEA(q, q_s, q_ss)`` without gravity, ``c = RNEA(q, 0, 0)`` with it.

The inertial parameters come from the URDF's ``<inertial>`` tags (sources in docs/robots.md); a
robot has dynamics when every moving link of its chain carries one (``has_inertials``). Each call
works on its own copy of the model (its gravity set from the request, in the base frame) and one
pool of scratch data (``pin.ModelPool``, batched RNEA in C++ from ``BATCH`` samples on, one
``pin.Data`` reused below it), so one object serves concurrent requests.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable

import numpy as np
import pinocchio as pin

from core.errors import InvalidURDF

BATCH = 48
"""From this many samples on, ``pin.rneaInParallel`` (one thread) is used: 2.6 against 6 us a
Panda sample, once its pool (about 180 us) is built."""


class RigidBodyDynamics:
    """Inverse dynamics of ``model`` (the chain's joints only, one dof each).

    Args:
        model: pinocchio model with the links' inertias (and ``armature``, the rotor inertia
            reflected through the gear [kg m^2], added to the diagonal of M).
        R_world_base: ``(3, 3)`` rotation of the robot's base frame in the model's world frame
            (gravity is given in the base frame).
    """

    def __init__(self, model: pin.Model, R_world_base: np.ndarray) -> None:
        self._model = model
        self._R = np.asarray(R_world_base, dtype=float)

    def _with_gravity(self, gravity: np.ndarray | None) -> pin.Model:
        model = pin.Model(self._model)
        g = np.zeros(3) if gravity is None else self._R @ np.asarray(gravity, dtype=float)
        model.gravity = pin.Motion(g, np.zeros(3))
        return model

    def _rnea(self, model: pin.Model, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """RNEA at the rows of ``q``, ``v``, ``a`` ``(N, dof)`` -> ``(N, dof)``."""
        n = len(q)
        if n >= BATCH:
            pool = pin.ModelPool(model, 1)
            tau = pin.rneaInParallel(1, pool, q.T.copy(), v.T.copy(), a.T.copy())
            return np.asarray(tau, dtype=float).reshape(model.nv, n).T.copy()
        data = model.createData()
        out = np.empty((n, model.nv))
        for i in range(n):
            out[i] = pin.rnea(model, data, q[i], v[i], a[i])
        return out

    def inverse_dynamics(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, gravity: np.ndarray
    ) -> np.ndarray:
        """``tau`` [N m or N] ``(N, dof)`` at the rows of ``q``, ``qd``, ``qdd`` ``(N, dof)``;
        ``gravity`` [m/s^2] in the base frame ``(3,)``."""
        q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
        return self._rnea(self._with_gravity(gravity), q, qd, qdd)

    def path_coefficients(
        self, q: np.ndarray, dq_ds: np.ndarray, d2q_ds2: np.ndarray, gravity: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(a, b, c)`` ``(N, dof)`` with ``tau = a s'' + b s'^2 + c`` along q(s): ``a = M q_s``,
        ``b = M q_ss + C(q, q_s) q_s``, ``c = g(q)``."""
        q, dq, ddq = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, dq_ds, d2q_ds2))
        free = self._with_gravity(None)
        zero = np.zeros_like(q)
        a = self._rnea(free, q, zero, dq)
        b = self._rnea(free, q, dq, ddq)
        c = self._rnea(self._with_gravity(gravity), q, zero, zero)
        return a, b, c


def has_inertials(urdf_xml: str, chain_joints: Iterable[str]) -> bool:
    """True when the child link of every joint in ``chain_joints`` (the robot's moving joints) has
    an ``<inertial>`` element in ``urdf_xml`` (already screened XML: no DTD, no entities)."""
    root = ET.fromstring(urdf_xml)
    links = {link.get("name"): link for link in root.iter("link")}
    children = {j.get("name"): j.find("child") for j in root.iter("joint")}
    for name in chain_joints:
        child = children.get(name)
        link = links.get(None if child is None else child.get("link"))
        if link is None or link.find("inertial") is None:
            return False
    return True


def effort_limits(model: pin.Model) -> np.ndarray | None:
    """The URDF's ``<limit effort>`` per joint [N m or N], or None unless every joint has one > 0
    (a URDF writes 0 where the effort is not known)."""
    effort = np.asarray(model.effortLimit, dtype=float)
    if effort.shape != (model.nv,) or not np.all(np.isfinite(effort) & (effort > 0.0)):
        return None
    return effort


MAX_MASS = 1e6
"""Largest link mass [kg] an inline URDF may give (and its inertia moments, [kg m^2])."""
_FIELD = ("robot", "urdf")


def screened_inertial(element: ET.Element | None, link: str) -> ET.Element | None:
    """A checked copy of a link's ``<inertial>`` (``origin``, ``mass``, ``inertia``), or None when
    it has none. ``InvalidURDF`` naming the link when a number is not finite, the origin is beyond
    1e4 m or rad, the mass is negative or over ``MAX_MASS``, or the inertia matrix is not
    symmetric positive semi-definite (a principal moment below -1e-12 of the largest)."""
    if element is None:
        return None
    where = f"link '{link if len(link) <= 64 else link[:61] + '...'}' inertial"

    def numbers(el: ET.Element | None, names: tuple[str, ...], default: float) -> list[float]:
        try:
            values = [float(default if el is None else el.get(n, default)) for n in names]
        except ValueError:
            raise InvalidURDF(f"{where} holds a value that is not a number", field=_FIELD) from None
        if not all(np.isfinite(values)):
            raise InvalidURDF(f"{where} holds a number that is not finite", field=_FIELD)
        return values

    def triple(el: ET.Element | None, attribute: str) -> list[float]:
        text = None if el is None else el.get(attribute)
        parts = [] if text is None else text.split()
        if text is not None and len(parts) != 3:
            raise InvalidURDF(f"{where} origin {attribute} needs 3 numbers", field=_FIELD)
        fake = ET.Element("v", {str(i): p for i, p in enumerate(parts)})
        return numbers(fake if parts else None, ("0", "1", "2"), 0.0)

    origin = element.find("origin")
    xyz, rpy = triple(origin, "xyz"), triple(origin, "rpy")
    if max(abs(v) for v in xyz + rpy) > 1e4:
        raise InvalidURDF(f"{where} origin is beyond 1e4 (m or rad)", field=_FIELD)
    (mass,) = numbers(element.find("mass"), ("value",), 0.0)
    moments = numbers(element.find("inertia"), ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 0.0)
    ixx, ixy, ixz, iyy, iyz, izz = moments
    eig = np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
    if not 0.0 <= mass <= MAX_MASS or max(abs(v) for v in moments) > MAX_MASS:
        raise InvalidURDF(f"{where} mass or inertia is negative or over 1e6", field=_FIELD)
    if eig[0] < -1e-12 * max(float(eig[-1]), 0.0) - 1e-300:
        raise InvalidURDF(f"{where} inertia matrix is not positive semi-definite", field=_FIELD)
    out = ET.Element("inertial")
    ET.SubElement(out, "origin", xyz=" ".join(map(repr, xyz)), rpy=" ".join(map(repr, rpy)))
    ET.SubElement(out, "mass", value=repr(mass))
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    ET.SubElement(out, "inertia", {n: repr(v) for n, v in zip(names, moments, strict=True)})
    return out
