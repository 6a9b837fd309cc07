"""What the collision check works on: obstacles in the base frame, and a robot's shapes fixed to its
joints.

Robot shapes are capsules (a sphere is a capsule of length 0), boxes and cylinders, each in the frame
of the pinocchio joint that carries it. Every shape also carries an enclosing capsule (the capsule
itself for a capsule): the cheap lower bound of its distances (``robots.collision.entries``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SHAPES = ("box", "sphere", "cylinder", "capsule", "halfspace")
"""Obstacle shape names (``Obstacle.shape``)."""
CAPSULE, BOX, CYLINDER = 0, 1, 2
"""Robot shape kinds (``RobotCollision.kind``); a sphere is a ``CAPSULE`` of length 0."""


@dataclass(frozen=True)
class Obstacle:
    """One obstacle, in the robot's base frame.

    Attributes:
        name: Unique among obstacles and different from every link name.
        shape: ``box`` (``size`` = full edge lengths [m]), ``sphere`` (``radius``), ``cylinder`` and
            ``capsule`` (``radius``, ``length`` along the local z axis, centred; a capsule's length is
            the distance between its hemisphere centres), ``halfspace`` (solid where
            ``normal . x <= offset``; no pose).
        T_base_obstacle: ``(4, 4)`` pose [m] (identity for a halfspace).
    """

    name: str
    shape: str
    size: tuple[float, ...] = ()
    radius: float = 0.0
    length: float = 0.0
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    T_base_obstacle: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass(frozen=True)
class RobotCollision:
    """A robot's collision shapes, attached to its pinocchio joints (built once per robot).

    Attributes:
        links: ``(G,)`` link name of each shape.
        joints: ``(G,)`` pinocchio joint index carrying each shape (0: the fixed root).
        kind: ``(G,)`` ``CAPSULE``, ``BOX`` or ``CYLINDER``.
        a, b, radius: ``(G, 3)``, ``(G, 3)``, ``(G,)``: the capsule [m] in the joint frame (for a box
            or a cylinder, a capsule that encloses it).
        frames: ``(G, 4, 4)`` the shape's frame in the joint frame: centre, and z along a capsule's
            segment or a cylinder's axis, a box's edges along its axes.
        dims: ``(G, 3)`` [m]: a box's half edge lengths; ``(radius, half length, 0)`` of a cylinder
            or a capsule.
        unchecked_links: Links whose collision geometry is mesh-only (not checked).
    """

    links: tuple[str, ...]
    joints: np.ndarray
    kind: np.ndarray
    a: np.ndarray
    b: np.ndarray
    radius: np.ndarray
    frames: np.ndarray
    dims: np.ndarray
    unchecked_links: tuple[str, ...] = ()

    def shape_extent(self, i: int) -> float:
        """[m] The largest distance of a point of shape ``i`` from its joint frame's origin (the
        lever of the motion bound): the farthest box corner, the farthest rim point of a
        cylinder's two end circles, a capsule's farther end plus its radius."""
        R, t, d = self.frames[i, :3, :3], self.frames[i, :3, 3], self.dims[i]
        if self.kind[i] == BOX:
            corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
            return float(np.linalg.norm(t + (corners * d) @ R.T, axis=1).max())
        if self.kind[i] == CYLINDER:
            z = R[:, 2]
            out = 0.0
            for m in (t - d[1] * z, t + d[1] * z):  # the centre of each end circle
                along = float(m @ z)
                across = float(np.linalg.norm(m - along * z))
                out = max(out, float(np.hypot(across + d[0], along)))
            return out
        return float(max(np.linalg.norm(self.a[i]), np.linalg.norm(self.b[i])) + self.radius[i])


def frame_with_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third column is the unit vector ``z``."""
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def capsule_frame(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """The frame ``(4, 4)`` of the capsule over segment ``a``-``b`` (centre, z along the segment)
    and its half length [m] (0 for a sphere)."""
    length = float(np.linalg.norm(b - a))
    z = (b - a) / length if length > 1e-12 else np.array([0.0, 0.0, 1.0])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = frame_with_z(z), (a + b) / 2
    return T, (length / 2 if length > 1e-12 else 0.0)
