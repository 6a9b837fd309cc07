"""The Cartesian straight line: position by lerp, orientation by slerp on the shorter arc.

A line runs from ``T_start`` to ``T_goal`` (4x4 tool poses in the base frame) over the path parameter
s in [0, 1]. For ``position_xy`` robots only x and y of the position count: the goal keeps the start's
z and orientation, and orientation deviation is zero by definition.

Deviation of a pose from the line is measured against the closest point of the line in SE(3): the
parameter s* minimizes ``|p - p(s)|^2 / tol_p^2 + angle(R(s)^T R)^2 / tol_o^2`` in its linearized
form, so a pose ahead of or behind its own sample along the line is not called a deviation, while a
pose whose orientation lags its position is.
The orientation deviation is the larger of the angle at s* and the angle at the closest point by
position alone, so the bound holds whichever of the two ways a client measures it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from core.geometry import so3
from core.path.base import PathDeviation, PosesFromParts

_EPS = 1e-12


class StraightLine(PosesFromParts):
    """The straight line from ``T_start`` to ``T_goal`` (4x4 ``T_base_tool`` each).

    Args:
        T_start: Start tool pose in the base frame.
        T_goal: Goal tool pose in the base frame.
        task_space: ``"pose"`` or ``"position_xy"``.
    """

    def __init__(self, T_start: np.ndarray, T_goal: np.ndarray, task_space: str = "pose") -> None:
        T_start = np.asarray(T_start, dtype=float)
        T_goal = np.array(T_goal, dtype=float)
        self.task_space = task_space
        if task_space == "position_xy":
            T_goal[2, 3] = T_start[2, 3]
            T_goal[:3, :3] = T_start[:3, :3]
        self.T_start = T_start
        self.T_goal = T_goal
        self.p0 = T_start[:3, 3].copy()
        self.delta_p = T_goal[:3, 3] - self.p0
        self.R0 = T_start[:3, :3].copy()
        # Rotation vector of R0^T R1 in [0, pi]: the shorter arc.
        self.rotvec = so3.log(self.R0.T @ T_goal[:3, :3])

    @property
    def length(self) -> float:
        """Distance [m] the tool travels."""
        return float(np.linalg.norm(self.delta_p))

    @property
    def angle(self) -> float:
        """Rotation [rad] the tool turns through (0 for ``position_xy``)."""
        return float(np.linalg.norm(self.rotvec))

    def positions(self, s: np.ndarray) -> np.ndarray:
        """Tool positions [m] at path parameters ``s`` (N,): shape (N, 3)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        return self.p0 + s[:, None] * self.delta_p

    def rotation_matrices(self, s: np.ndarray) -> np.ndarray:
        """Tool orientations ``(N, 3, 3)`` at ``s`` (N,): slerp on the shorter arc (``so3.slerp``)."""
        return so3.slerp(self.R0, self.rotvec, s)

    def twist(self, s_dot: np.ndarray) -> np.ndarray:
        """Tool twist (N, 6) in the base frame for path speeds ``s_dot`` [1/s]: [v (m/s), w (rad/s)].

        The angular velocity of slerp is constant in the base frame: ``R0 @ rotvec * s_dot``.
        """
        s_dot = np.atleast_1d(np.asarray(s_dot, dtype=float))
        omega = self.R0 @ self.rotvec
        return np.hstack([s_dot[:, None] * self.delta_p, s_dot[:, None] * omega])

    def derivative(self, s: np.ndarray) -> np.ndarray:
        """``(N, 6)`` d(pose)/ds at ``s`` (N,): constant along a line, ``[delta_p, R0 rotvec]``."""
        return self.twist(np.ones(np.size(s)))

    def deviation(
        self,
        T: np.ndarray,
        position_tolerance: float = 1e-3,
        orientation_tolerance: float = 1e-2,
    ) -> PathDeviation:
        """Deviation of poses ``T`` (N, 4, 4) from the line (see the module docstring).

        The tolerances [m], [rad] only weigh position against orientation when choosing the closest
        line point; they do not clip anything.
        """
        T = np.asarray(T, dtype=float).reshape(-1, 4, 4)
        p = T[:, :3, 3]
        rows = 2 if self.task_space == "position_xy" else 3
        d = self.delta_p[:rows]
        length_sq = float(d @ d)
        s_pos = (
            (p[:, :rows] - self.p0[:rows]) @ d / length_sq if length_sq > _EPS else 0.0 * p[:, 0]
        )
        w_pos = length_sq / position_tolerance**2
        if self.task_space == "position_xy":
            s_rot, w_rot = np.zeros(len(T)), 0.0
        else:
            theta_sq = float(self.rotvec @ self.rotvec)
            rel = so3.log(self.R0.T @ T[:, :3, :3])
            # Near a half turn the rotation vector may come out as -rel (angle pi about the opposite
            # axis); the same rotation is also rel (1 - 2 pi / |rel|): use the one nearer the line.
            angle = _norms(rel)[:, None]
            alt = rel * (1.0 - 2.0 * np.pi / np.maximum(angle, _EPS))
            if theta_sq > _EPS:
                s_a, s_b = rel @ self.rotvec / theta_sq, alt @ self.rotvec / theta_sq
                d_a = _norms(rel - np.clip(s_a, 0.0, 1.0)[:, None] * self.rotvec)
                d_b = _norms(alt - np.clip(s_b, 0.0, 1.0)[:, None] * self.rotvec)
                s_rot = np.where(d_b < d_a, s_b, s_a)
            else:
                s_rot = np.zeros(len(T))
            w_rot = theta_sq / orientation_tolerance**2
        if w_pos + w_rot > 0.0:
            s = (w_pos * s_pos + w_rot * s_rot) / (w_pos + w_rot)
        else:
            s = np.zeros(len(T))
        s = np.clip(s, 0.0, 1.0)
        position = _norms(p[:, :rows] - self.positions(s)[:, :rows])
        if self.task_space == "position_xy":
            orientation = np.zeros(len(T))
        else:
            angle_at = self._angles(self.R0.T @ T[:, :3, :3])
            orientation = angle_at(s)
            if length_sq > _EPS:
                # Also against the line's orientation at the closest point by position alone, the
                # way a client measuring distance to the segment first would: the larger counts.
                orientation = np.maximum(orientation, angle_at(np.clip(s_pos, 0.0, 1.0)))
        return PathDeviation(s=s, position=position, orientation=orientation)

    def _angles(self, rel: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """``s -> angle(R(s)^T R)`` [rad] for the orientations ``R = R0 rel`` (``rel`` (N, 3, 3)):
        ``R(s)^T R = exp(-s theta [k]) rel = rel - sin(s theta) [k] rel + (1 - cos(s theta))
        [k]^2 rel`` (Rodrigues about the line's one axis ``k``), so the skew part and the trace
        that give the angle (``so3.rotation_angle``) are the same combination of those of the
        three products, computed once for any number of ``s``."""
        theta = self.angle

        def parts(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            w = np.stack(
                [M[:, 2, 1] - M[:, 1, 2], M[:, 0, 2] - M[:, 2, 0], M[:, 1, 0] - M[:, 0, 1]],
                axis=1,
            )
            return w, M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2]

        w_a, t_a = parts(rel)
        if theta > _EPS:
            K = so3.skew(self.rotvec / theta)
            w_b, t_b = parts(K @ rel)
            w_c, t_c = parts(K @ K @ rel)
        else:
            w_b = w_c = np.zeros_like(w_a)
            t_b = t_c = np.zeros_like(t_a)

        def angle(s: np.ndarray) -> np.ndarray:
            sn, cs = np.sin(s * theta), 1.0 - np.cos(s * theta)
            w = w_a - sn[:, None] * w_b + cs[:, None] * w_c
            trace = t_a - sn * t_b + cs * t_c
            return np.arctan2(0.5 * _norms(w), 0.5 * (trace - 1.0))

        return angle


def _norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norms of the rows of ``v`` (N, k) (np.linalg.norm's values, without its
    per-call overhead: a third of the time for a few thousand rows)."""
    return np.sqrt(np.einsum("ij,ij->i", v, v))


def pose_error(T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    """Position distance [m] and orientation angle [rad] between two poses (4, 4)."""
    dp = float(np.linalg.norm(T_a[:3, 3] - T_b[:3, 3]))
    return dp, float(so3.rotation_angle(T_a[:3, :3].T @ T_b[:3, :3]))
