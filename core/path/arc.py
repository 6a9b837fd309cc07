"""The circular arc (CIRC): the tool point on a circle, orientation by slerp on the shorter arc.

An arc runs from ``T_start`` to ``T_goal`` (4x4 tool poses in the base frame) over the path
parameter s in [0, 1], like ``core.path.line.StraightLine`` (same members, so it can sit in the PATHS
registry as ``"circ"``). The circle is given one of two ways:

- ``interim``: a point [m] the arc passes through; the circle is the one through the start, interim
  and goal positions, and the arc is the one from start to goal that contains the interim point
  (it may exceed a half turn). Collinear points have no unique circle: ``InputError``.
- ``center``: the circle's centre [m]; start and goal must be equidistant from it (within
  ``CENTER_TOLERANCE``), and the arc is the shorter one (a half turn has no unique plane:
  ``InputError``).

Position at s: ``c + r (cos(s theta) u + sin(s theta) v)`` with ``u`` towards the start and ``v``
in the circle's plane, ``theta`` the swept angle [rad]. Orientation: the same slerp as a line.
"""

from __future__ import annotations

import numpy as np

from core.errors import InputError
from core.geometry import so3
from core.path.base import PathDeviation, PosesFromParts
from core.path.line import StraightLine

CENTER_TOLERANCE = 1e-4
"""Largest difference [m] between the start's and the goal's distance from ``center``."""
COLLINEAR_TOLERANCE = 1e-6
"""Smallest distance [m] of the interim point from the start-goal chord (and of the start and goal
from each other) for a unique circle."""
_EPS = 1e-12


class Arc(PosesFromParts):
    """The circular arc from ``T_start`` to ``T_goal`` through ``interim`` or about ``center``.

    Args:
        T_start: Start tool pose (4, 4) in the base frame.
        T_goal: Goal tool pose (4, 4).
        interim: A point (3,) [m] on the arc, or None.
        center: The circle's centre (3,) [m], or None (exactly one of the two).
        task_space: ``"pose"`` (``"position_xy"`` keeps the start's z and orientation, as a line).
        field: Request location prefix for ``InputError`` (for example ``("segments", 3)``).
    """

    def __init__(
        self,
        T_start: np.ndarray,
        T_goal: np.ndarray,
        *,
        interim: np.ndarray | None = None,
        center: np.ndarray | None = None,
        task_space: str = "pose",
        field: tuple[str | int, ...] = (),
    ) -> None:
        if (interim is None) == (center is None):
            raise InputError("give exactly one of interim or center", field=(*field, "interim"))
        self._slerp = StraightLine(T_start, T_goal, task_space)
        self.task_space = task_space
        self.T_start, self.T_goal = self._slerp.T_start, self._slerp.T_goal
        p0, p1 = self.T_start[:3, 3], self.T_goal[:3, 3]
        if np.linalg.norm(p1 - p0) < COLLINEAR_TOLERANCE:
            raise InputError(
                "a circ segment needs distinct start and goal positions", field=(*field, "goal")
            )
        if interim is not None:
            self.center, normal, theta = _through(p0, np.asarray(interim, float), p1, field)
            r1 = r0 = float(np.linalg.norm(p0 - self.center))
        else:
            self.center = np.asarray(center, dtype=float)
            r0 = float(np.linalg.norm(p0 - self.center))
            r1 = float(np.linalg.norm(p1 - self.center))
            if abs(r0 - r1) > CENTER_TOLERANCE:
                raise InputError(
                    f"start and goal are not equidistant from center (within {CENTER_TOLERANCE:g} m)",
                    field=(*field, "center"),
                )
            a, b = p0 - self.center, p1 - self.center
            cross = np.cross(a, b)
            if r0 < COLLINEAR_TOLERANCE or np.linalg.norm(cross) < COLLINEAR_TOLERANCE * r0:
                raise InputError(
                    "center is on the start-goal line (a half turn or none): no unique arc",
                    field=(*field, "center"),
                )
            normal = cross / np.linalg.norm(cross)
            theta = float(np.arctan2(np.linalg.norm(cross), a @ b))
        self.r0, self.r1 = r0, r1
        self.radius = r0
        self.normal = normal
        self.u = (p0 - self.center) / r0
        self.v = np.cross(normal, self.u)
        self.theta = theta

    @property
    def length(self) -> float:
        """Arc length [m] the tool point travels."""
        return float(0.5 * (self.r0 + self.r1) * self.theta)

    @property
    def angle(self) -> float:
        """Rotation [rad] the tool turns through."""
        return self._slerp.angle

    @property
    def R0(self) -> np.ndarray:
        return self._slerp.R0

    @property
    def rotvec(self) -> np.ndarray:
        return self._slerp.rotvec

    def _radius(self, s: np.ndarray) -> np.ndarray:
        return self.r0 + s * (self.r1 - self.r0)

    def positions(self, s: np.ndarray) -> np.ndarray:
        """Tool positions [m] at ``s`` (N,): (N, 3); exactly the start and goal at 0 and 1."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        phi = s * self.theta
        p = self.center + self._radius(s)[:, None] * (
            np.cos(phi)[:, None] * self.u + np.sin(phi)[:, None] * self.v
        )
        p[s == 0.0] = self.T_start[:3, 3]
        p[s == 1.0] = self.T_goal[:3, 3]
        return p

    def tangents(self, s: np.ndarray) -> np.ndarray:
        """dp/ds [m per unit s] at ``s`` (N,): (N, 3)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        phi = s * self.theta
        radial = np.cos(phi)[:, None] * self.u + np.sin(phi)[:, None] * self.v
        along = -np.sin(phi)[:, None] * self.u + np.cos(phi)[:, None] * self.v
        return (self._radius(s) * self.theta)[:, None] * along + (self.r1 - self.r0) * radial

    def rotation_matrices(self, s: np.ndarray) -> np.ndarray:
        """Tool orientation matrices (N, 3, 3) at ``s`` (N,)."""
        return self._slerp.rotation_matrices(s)

    def twist(self, s_dot: np.ndarray, s: np.ndarray | float = 0.0) -> np.ndarray:
        """Tool twist (N, 6) [m/s, rad/s] in the base frame at path parameters ``s`` and speeds
        ``s_dot`` [1/s] (a line's twist does not depend on s; an arc's linear part does)."""
        s_dot = np.atleast_1d(np.asarray(s_dot, dtype=float))
        s = np.broadcast_to(np.asarray(s, dtype=float), s_dot.shape)
        omega = self.R0 @ self.rotvec
        return np.hstack([s_dot[:, None] * self.tangents(s), s_dot[:, None] * omega])

    def derivative(self, s: np.ndarray) -> np.ndarray:
        """``(N, 6)`` d(pose)/ds at ``s`` (N,): ``[dp/ds (m), R0 rotvec (rad)]`` (the Path Protocol;
        the linear part turns with s)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        return self.twist(np.ones(s.size), s)

    def deviation(
        self, T: np.ndarray, position_tolerance: float = 1e-3, orientation_tolerance: float = 1e-2
    ) -> PathDeviation:
        """Deviation of poses ``T`` (N, 4, 4) from the arc: ``s`` of the closest arc point by
        angle about the centre (clipped to the arc), the distance to it [m] and the orientation
        angle to the slerp there [rad]. The tolerances are accepted for the line's signature."""
        T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
        d = T[:, :3, 3] - self.center
        phi = np.mod(np.arctan2(d @ self.v, d @ self.u), 2.0 * np.pi)
        # Beyond the arc's end: the nearer of its two ends.
        past = phi > self.theta
        to_end = phi - self.theta
        to_start = 2.0 * np.pi - phi
        s = np.where(past, np.where(to_end < to_start, 1.0, 0.0), phi / max(self.theta, _EPS))
        if self.task_space == "position_xy":  # x and y only; orientation does not count
            position = np.linalg.norm(T[:, :2, 3] - self.positions(s)[:, :2], axis=1)
            return PathDeviation(s=s, position=position, orientation=np.zeros(len(T)))
        position = np.linalg.norm(T[:, :3, 3] - self.positions(s), axis=1)
        err = np.swapaxes(self.rotation_matrices(s), 1, 2) @ T[:, :3, :3]
        orientation = np.linalg.norm(so3.log(err), axis=1)
        return PathDeviation(s=s, position=position, orientation=orientation)


def _through(
    p0: np.ndarray, pi: np.ndarray, p1: np.ndarray, field: tuple[str | int, ...]
) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre, unit normal (the arc turns positively about it) and swept angle [rad] of the arc
    from ``p0`` through ``pi`` to ``p1``."""
    a, b = pi - p0, p1 - p0
    cross = np.cross(a, b)
    area2 = float(np.linalg.norm(cross))
    chord = float(np.linalg.norm(b))
    # Distance of the interim point from the chord line (and from each end).
    if (
        area2 < COLLINEAR_TOLERANCE * chord
        or np.linalg.norm(a) < COLLINEAR_TOLERANCE
        or np.linalg.norm(pi - p1) < COLLINEAR_TOLERANCE
    ):
        raise InputError(
            "interim is collinear with the start and goal positions: no unique circle",
            field=(*field, "interim"),
        )
    # Circumcentre of the triangle (p0, pi, p1).
    center = p0 + (np.cross(cross, a) * (b @ b) + np.cross(b, cross) * (a @ a)) / (2.0 * area2**2)
    normal = cross / area2
    u = (p0 - center) / np.linalg.norm(p0 - center)
    v = np.cross(normal, u)

    def angle(p: np.ndarray) -> float:
        d = p - center
        return float(np.mod(np.arctan2(d @ v, d @ u), 2.0 * np.pi))

    # With normal = a x b the turn p0 -> pi -> p1 is positive: interim comes first.
    theta_i, theta_1 = angle(pi), angle(p1)
    if theta_i > theta_1:  # numerically impossible for a proper triangle; turn the other way
        normal = -normal
        theta_1 = 2.0 * np.pi - theta_1
    return center, normal, theta_1
