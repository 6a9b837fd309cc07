"""A geometric joint path through waypoints: straight joint segments with circular corner blends.

``BlendedPath`` implements ``core.timing.joint_path.JointPath`` for the retime endpoint's
``"path": "blended"``, built as MoveIt's time-optimal trajectory generation builds its path (Kunz
and Stilman, "Time-optimal trajectory generation for path following with bounded acceleration and
velocity", RSS 2012; moveit_core ``time_optimal_trajectory_generation.cpp``, ``CircularPathSegment``):
at every interior waypoint the corner between the two straight segments is replaced by the circular
arc tangent to both, whose closest point is at most ``max_deviation`` from the corner and which uses
at most half of either segment. With turning angle theta and distance d from the corner to the
arc's ends along each segment, the arc's radius is ``d / tan(theta / 2)`` and its deviation
``d (1 - cos(theta / 2)) / sin(theta / 2)``, so ``d = min(half segments, max_deviation sin(theta/2) /
(1 - cos(theta/2)))``.

s is the arc length [rad or m] (|dq/ds| = 1), so the derivatives are exact: a line has dq/ds = its
direction and d2q/ds2 = 0; an arc of radius r, q = c + r (x cos(phi/r) + y sin(phi/r)), has
d2q/ds2 of length 1/r. Corners that turn by less than ``COLLINEAR`` are straight; corners that turn
back by more than pi - ``REVERSAL`` get no arc: dq/ds reverses there, and a timing law must stop
(``core.timing.topp`` stops wherever dq/ds jumps).
"""

from __future__ import annotations

import numpy as np

COLLINEAR = 1e-10
"""Turning angle [rad] below which a corner is straight (no arc)."""
REVERSAL = 1e-6
"""A corner turning by more than pi minus this [rad] reverses: no arc, the motion stops there."""


class BlendedPath:
    """q(s), s in [0, ``length``], along ``waypoints`` ``(n, dof)`` (n >= 2, consecutive ones
    distinct) with corners rounded within ``max_deviation`` [rad or m] (> 0)."""

    def __init__(self, waypoints: np.ndarray, max_deviation: float) -> None:
        q = np.asarray(waypoints, dtype=float)
        self.dof = int(q.shape[1])
        seg = np.diff(q, axis=0)
        seglen = np.linalg.norm(seg, axis=1)
        d = seg / seglen[:, None]
        n = len(q)
        dist = np.zeros(n)  # distance from each corner to its arc's ends along the segments
        arcs: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, float, float]] = {}
        for k in range(1, n - 1):
            d0, d1 = d[k - 1], d[k]
            theta = 2.0 * np.arctan2(np.linalg.norm(d1 - d0), np.linalg.norm(d1 + d0))
            if theta < COLLINEAR or theta > np.pi - REVERSAL:
                continue
            half = 0.5 * theta
            reach = max_deviation * np.sin(half) / (2.0 * np.sin(0.5 * half) ** 2)
            dist[k] = min(0.5 * seglen[k - 1], 0.5 * seglen[k], reach)
            r = float(dist[k] / np.tan(half))
            bisector = (d1 - d0) / np.linalg.norm(d1 - d0)
            center = q[k] + bisector * (r / np.cos(half))
            x = q[k] - dist[k] * d0 - center
            arcs[k] = (center, x / np.linalg.norm(x), d0, r, r * float(theta))
        origin: list[np.ndarray] = []
        e1: list[np.ndarray] = []
        e2: list[np.ndarray] = []
        radius: list[float] = []
        lengths: list[float] = []
        for k in range(n - 1):
            if k in arcs:
                c, x, y, r_k, length = arcs[k]
                for target, value in ((origin, c), (e1, x), (e2, y)):
                    target.append(value)
                radius.append(r_k)
                lengths.append(length)
            line = seglen[k] - dist[k] - dist[k + 1]
            if line > 0.0 or (k == n - 2 and not lengths):
                origin.append(q[k] + dist[k] * d[k])
                e1.append(d[k])
                e2.append(np.zeros(self.dof))
                radius.append(np.inf)
                lengths.append(line)
        self._origin, self._e1, self._e2 = np.array(origin), np.array(e1), np.array(e2)
        self._radius = np.array(radius)
        self._starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
        self._lengths = np.array(lengths)
        self.length = float(np.sum(lengths))
        self.arcs = len(arcs)

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q [rad or m] (``order=0``), dq/ds (1), d2q/ds2 (2) or d3q/ds3 (3) at ``s`` ``(K,)``
        (clipped to [0, length]; at a junction, the piece that starts there): ``(K, dof)``."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        k = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, len(self._starts) - 1)
        phi = np.clip(s - self._starts[k], 0.0, self._lengths[k])[:, None]
        r = self._radius[k][:, None]
        arc = np.isfinite(r)
        rr = np.where(arc, r, 1.0)
        ang = np.where(arc, phi / rr, 0.0)
        c, sn = np.cos(ang), np.sin(ang)
        e1, e2 = self._e1[k], self._e2[k]
        if order == 0:
            return self._origin[k] + np.where(arc, rr * (e1 * c + e2 * sn), phi * e1)
        if order == 1:
            return np.where(arc, e2 * c - e1 * sn, e1)
        if order == 2:
            return np.where(arc, -(e1 * c + e2 * sn) / rr, 0.0)
        return np.where(arc, (e1 * sn - e2 * c) / rr**2, 0.0)

    def breakpoints(self) -> np.ndarray:
        """Where pieces join (d2q/ds2 jumps), 0 and ``length`` included ``(B,)``."""
        return np.concatenate([self._starts, [self.length]])
