"""A geometric joint path through knots: straight joint segments with circular corner blends.

``BlendedPath`` implements ``core.timing.joint_path.JointPath``; it is the retime endpoint's
``"path": "blended"`` and a collision-free motion's geometric path (``core.motion.plan.blend``).
It is built as MoveIt's time-optimal trajectory generation builds its path (Kunz and Stilman,
"Time-optimal trajectory generation for path following with bounded acceleration and velocity",
RSS 2012; moveit_core ``time_optimal_trajectory_generation.cpp``, ``CircularPathSegment``): each
interior corner is rounded by an arc of a circle in the plane of its two segments, tangent to
both. With unit directions ``y_a`` in and ``y_b`` out and the turn angle ``alpha``, the arc leaves
the corner's segments ``l`` before and after it, ``l = min(|seg_a| / 2, |seg_b| / 2, deviation /
tan(alpha / 4))``, so it passes within ``deviation`` [rad or m] of the corner; its radius is
``r = l / tan(alpha / 2)``. One deviation for every corner (retime's ``max_deviation``) or one per
knot (a collision-free motion certifies each blend by its own corner's margins).

The path parameter s is joint-space arc length, so ``|dq/ds| = 1`` and every derivative is exact:
on a line dq/ds is its direction and d2q/ds2 = d3q/ds3 = 0; an arc ``q(phi) = start + r (sin(phi)
y + (1 - cos(phi)) n)``, ``phi = u / r``, is written without its centre and with ``1 - cos`` as
``2 sin^2(phi / 2)``, so an arc of a huge radius (a corner that barely turns) stays exact. Corners
that turn by less than ``STRAIGHT`` are straight; a corner whose deviation is 0, or that turns back
by more than ``pi - REVERSAL``, stays sharp: dq/ds jumps there, so a timing law stops there
(``stops``; ``core.timing.topp`` stops wherever dq/ds jumps). Units: [rad or m].
"""

from __future__ import annotations

import numpy as np

SHORTEST = 1e-12
"""A line between two blends shorter than this (relative to the path length so far) is dropped:
its path parameter would not advance in double precision."""
STRAIGHT = 1e-9
"""[rad] Turns smaller than this are not corners (neither blended nor stopped at)."""
REVERSAL = 1e-6
"""[rad] A corner turning by more than pi minus this reverses: no arc, the motion stops there."""


class BlendedPath:
    """q(s), s in [0, ``length``], along the straight segments through ``knots`` ``(K, dof)``,
    corner k rounded within ``deviations`` [rad or m]: one value for every corner, or one per knot
    (the ends' ignored); default none: every corner sharp. Consecutive knots may repeat (a segment
    of zero length is skipped).

    Attributes:
        knots: ``(K, dof)``.
        deviations: ``(K,)`` per knot.
        length: [rad or m] arc length of the path.
        arcs: Number of rounded corners.
    """

    def __init__(self, knots: np.ndarray, deviations: float | np.ndarray | None = None) -> None:
        knots = np.asarray(knots, dtype=float)
        self.knots = knots
        self.dof = int(knots.shape[1])
        K = len(knots)
        dev = np.zeros(K) if deviations is None else np.asarray(deviations, dtype=float)
        self.deviations = np.broadcast_to(dev, (K,)).copy()
        seg = np.diff(knots, axis=0)
        length = np.linalg.norm(seg, axis=1)
        unit = seg / np.where(length > 0, length, 1.0)[:, None]
        reach = np.zeros(K)  # how far each corner's arc reaches along its segments
        arcs: dict[int, tuple[np.ndarray, float, np.ndarray, float]] = {}
        for k in range(1, K - 1):
            arc = _arc(unit[k - 1], unit[k], length[k - 1], length[k], self.deviations[k])
            if arc is not None:
                arcs[k] = arc
                reach[k] = arc[1] * np.tan(arc[3] / 2)
        # pieces, in order: a start point, y, n (zero on lines), radius (inf on lines), length
        start, y, n, radius, size = [], [], [], [], []
        total = 0.0
        for k in range(K - 1):
            line = float(max(length[k] - reach[k] - reach[k + 1], 0.0))
            if line > SHORTEST * max(1.0, total):  # shorter: lost in the sum of lengths
                start.append(knots[k] + reach[k] * unit[k])
                y.append(unit[k])
                n.append(np.zeros(self.dof))
                radius.append(np.inf)
                size.append(line)
                total += line
            if k + 1 in arcs:
                normal, r, y_in, angle = arcs[k + 1]
                start.append(knots[k + 1] - reach[k + 1] * y_in)
                y.append(y_in)
                n.append(normal)
                radius.append(r)
                size.append(r * angle)
                total += r * angle
        if not size:  # every knot the same: one line of zero length
            start, y, n = [knots[0]], [np.zeros(self.dof)], [np.zeros(self.dof)]
            radius, size = [np.inf], [0.0]
        self._start, self._y, self._n = np.array(start), np.array(y), np.array(n)
        self._radius = np.array(radius)
        self._size = np.array(size)
        self._starts = np.concatenate([[0.0], np.cumsum(size)[:-1]])
        self.length = float(np.sum(size))
        self.arcs = len(arcs)
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", unit[:-1], unit[1:]), -1.0, 1.0))
        sharp = [k for k in range(1, K - 1) if k not in arcs and turn[k - 1] >= STRAIGHT
                 and length[k - 1] > 0 and length[k] > 0]  # fmt: skip
        # a sharp knot's s: its distance along the polyline less what the arcs before it cut off
        cut = np.zeros(K)
        for k, (_, r, _, angle) in arcs.items():
            cut[k] = 2 * reach[k] - r * angle
        polyline = np.concatenate([[0.0], np.cumsum(length)])
        self._stops = np.array([polyline[k] - cut[:k].sum() for k in sharp])

    def stops(self) -> np.ndarray:
        """Path parameters of the sharp corners, where the direction turns: the motion must come
        to rest there."""
        return self._stops.copy()

    def breakpoints(self) -> np.ndarray:
        """Path parameters ``(B,)`` where pieces meet (d2q/ds2 may jump), 0 and ``length``
        included."""
        return np.concatenate([self._starts, [self.length]])

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q (``order=0``), dq/ds (1), d2q/ds2 (2) or d3q/ds3 (3) at ``s`` ``(n,)`` (clipped to
        [0, length]; at a junction, the piece that starts there): ``(n, dof)``, exact."""
        s = np.clip(np.asarray(s, dtype=float).reshape(-1), 0.0, self.length)
        k = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, len(self._starts) - 1)
        u = np.clip(s - self._starts[k], 0.0, self._size[k])[:, None]
        r = self._radius[k][:, None]
        arc = np.isfinite(r)
        rr = np.where(arc, r, 1.0)
        phi = np.where(arc, u / rr, 0.0)
        y, n = self._y[k], self._n[k]
        c, sn = np.cos(phi), np.sin(phi)
        if order == 0:
            bend = 2.0 * np.sin(phi / 2) ** 2
            return self._start[k] + np.where(arc, rr * (sn * y + bend * n), u * y)
        if order == 1:
            return np.where(arc, c * y + sn * n, y)
        if order == 2:
            return np.where(arc, (c * n - sn * y) / rr, 0.0)
        return np.where(arc, -(sn * n + c * y) / rr**2, 0.0)


def _arc(
    y_a: np.ndarray, y_b: np.ndarray, len_a: float, len_b: float, deviation: float
) -> tuple[np.ndarray, float, np.ndarray, float] | None:
    """The blend of one corner, ``(n, radius, y_a, angle)`` (``n``: the unit normal towards the
    centre), or None when it stays sharp (no deviation allowed, no turn, a reversal, or a segment
    of zero length)."""
    if deviation <= 0 or len_a <= 0 or len_b <= 0:
        return None
    angle = float(2.0 * np.arctan2(np.linalg.norm(y_b - y_a), np.linalg.norm(y_b + y_a)))
    if angle < STRAIGHT or angle > np.pi - REVERSAL:
        return None
    half = angle / 2
    reach = min(len_a / 2, len_b / 2, deviation / np.tan(half / 2))
    n = y_b - (y_a @ y_b) * y_a  # the part of the outgoing direction across the incoming one
    n /= np.linalg.norm(n)
    return n, float(reach / np.tan(half)), y_a.copy(), angle
