"""The geometric path of a collision-free motion: straight joint segments with circular blends.

Through knots q_0 .. q_{K-1}, each interior corner is rounded by an arc of a circle in the plane of
its two segments, tangent to both (Kunz and Stilman, "Time-optimal trajectory generation for path
following with bounded acceleration and velocity", RSS 2012): with unit directions ``y_a`` in and
``y_b`` out and the turn angle ``alpha``, the arc leaves the corner's segments ``l`` before and
after it, ``l = min(|seg_a| / 2, |seg_b| / 2, deviation / tan(alpha / 4))``, so it passes within
``deviation`` [rad] of the corner; its radius is ``r = l / tan(alpha / 2)``. The path
parameter s is joint-space arc length, so ``|dq/ds| = 1``, and every derivative is exact:
``d2q/ds2 = 0`` on the lines and the normal towards the centre over ``r`` on the arcs. A deviation of 0 keeps a corner
sharp: the direction turns there, so the motion stops there (``stops``). ``BlendedPath`` implements ``core.timing.joint_path.JointPath``.

``speed_bounds`` gives, per piece, a bound on how far each joint moves per unit s (a line: its
direction's components; an arc: ``sqrt(y_j^2 + n_j^2)`` of its two unit axes), the input of
``core.motion.certify.certify``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SHORTEST = 1e-12
"""A line between two blends shorter than this (relative to the path length so far) is dropped:
its path parameter would not advance in double precision."""
STRAIGHT = 1e-9
"""[rad] Turns smaller than this are not corners (neither blended nor stopped at)."""


@dataclass(frozen=True)
class Arc:
    """A blend: ``q(phi) = start + radius (sin(phi) y + (1 - cos(phi)) n)``, ``phi`` in
    ``[0, angle]`` (written without the centre, and ``1 - cos`` as ``2 sin^2(phi / 2)``, so an
    arc of a huge radius through a corner that barely turns stays exact).

    Attributes:
        corner: Index of the knot it rounds.
        start: ``(dof,)`` where it leaves the incoming segment.
        radius: [rad] > 0.
        y, n: ``(dof,)`` orthonormal: the incoming direction and the normal towards the centre.
        angle: Turn angle [rad] in (0, pi).
    """

    corner: int
    start: np.ndarray
    radius: float
    y: np.ndarray
    n: np.ndarray
    angle: float


class BlendedPath:
    """Straight segments through ``knots`` ``(K, dof)``, corner k rounded within ``deviations[k]``
    [rad] (one per knot; the ends' are ignored; default none: every corner sharp)."""

    def __init__(self, knots: np.ndarray, deviations: np.ndarray | None = None) -> None:
        knots = np.asarray(knots, dtype=float)
        self.knots = knots
        self.dof = int(knots.shape[1])
        K = len(knots)
        dev = np.zeros(K) if deviations is None else np.asarray(deviations, dtype=float)
        self.deviations = dev
        seg = np.diff(knots, axis=0)
        length = np.linalg.norm(seg, axis=1)
        unit = seg / np.where(length > 0, length, 1.0)[:, None]
        cut = np.zeros(K)  # how far each corner's arc reaches along its segments
        arcs: dict[int, Arc] = {}
        for k in range(1, K - 1):
            arc = _arc(knots[k], unit[k - 1], unit[k], length[k - 1], length[k], dev[k], k)
            if arc is not None:
                arcs[k] = arc
                cut[k] = arc.radius * np.tan(arc.angle / 2)
        # pieces: ("line", a, b) or ("arc", Arc) in order; s at every piece start
        pieces: list[tuple[str, object]] = []
        starts = [0.0]
        for k in range(K - 1):
            a = knots[k] + cut[k] * unit[k]
            line = float(max(length[k] - cut[k] - cut[k + 1], 0.0))
            if line > SHORTEST * max(1.0, starts[-1]):  # shorter: lost in the sum of lengths
                pieces.append(("line", (a, unit[k])))
                starts.append(starts[-1] + line)
            if k + 1 in arcs:
                arc = arcs[k + 1]
                pieces.append(("arc", arc))
                starts.append(starts[-1] + arc.radius * arc.angle)
        if not pieces:  # every knot the same
            pieces.append(("line", (knots[0], np.zeros(self.dof))))
            starts.append(0.0)
        self._pieces = pieces
        self._starts = np.array(starts)
        self.arcs = arcs
        self.length = float(self._starts[-1])
        turn = np.arccos(np.clip(np.einsum("ij,ij->i", unit[:-1], unit[1:]), -1.0, 1.0))
        sharp = [k for k in range(1, K - 1) if k not in arcs and turn[k - 1] >= STRAIGHT
                 and length[k - 1] > 0 and length[k] > 0]  # fmt: skip
        cum = np.concatenate([[0.0], np.cumsum(length)])
        self._stops = np.array([self._at_knot(k, cum, cut, arcs) for k in sharp])

    def _at_knot(self, k: int, cum: np.ndarray, cut: np.ndarray, arcs: dict[int, Arc]) -> float:
        """Path parameter of knot k (a sharp corner): its distance along the polyline minus what
        the arcs before it cut off."""
        s = float(cum[k])
        for j, arc in arcs.items():
            if j < k:
                s -= 2 * cut[j] - arc.radius * arc.angle
        return s

    def stops(self) -> np.ndarray:
        """Path parameters of the sharp corners, where the direction turns: the motion must come
        to rest there."""
        return self._stops.copy()

    def breakpoints(self) -> np.ndarray:
        """Path parameters ``(B,)`` where pieces meet, 0 and ``length`` included."""
        return self._starts.copy()

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q (``order=0``), dq/ds (1) or d2q/ds2 (2) at ``s`` ``(n,)``: ``(n, dof)``, exact."""
        s = np.clip(np.asarray(s, dtype=float).reshape(-1), 0.0, self.length)
        idx = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, len(self._pieces) - 1)
        out = np.empty((len(s), self.dof))
        for i in np.unique(idx):
            mask = idx == i
            u = s[mask] - self._starts[i]
            kind, data = self._pieces[i]
            if kind == "line":
                a, d = data  # type: ignore[misc]
                out[mask] = (a + u[:, None] * d) if order == 0 else (d if order == 1 else 0.0)
                continue
            arc: Arc = data  # type: ignore[assignment]
            phi = (u / arc.radius)[:, None]
            c, sn = np.cos(phi), np.sin(phi)
            if order == 0:
                bend = 2.0 * np.sin(phi / 2) ** 2
                out[mask] = arc.start + arc.radius * (sn * arc.y + bend * arc.n)
            elif order == 1:
                out[mask] = c * arc.y + sn * arc.n
            else:
                out[mask] = (c * arc.n - sn * arc.y) / arc.radius
        return out

    def speed_bounds(self) -> np.ndarray:
        """``(pieces, dof)``: on each piece, the most each joint moves per unit s."""
        rows = []
        for kind, data in self._pieces:
            if kind == "line":
                rows.append(np.abs(data[1]))  # type: ignore[index]
            else:
                arc: Arc = data  # type: ignore[assignment]
                rows.append(np.hypot(arc.y, arc.n))
        return np.array(rows)

    def curvature_bounds(self) -> np.ndarray:
        """``(pieces, dof)``: on each piece, a bound on |d2q/ds2| per joint (0 on lines)."""
        rows = []
        for kind, data in self._pieces:
            if kind == "line":
                rows.append(np.zeros(self.dof))
            else:
                arc: Arc = data  # type: ignore[assignment]
                rows.append(np.hypot(arc.y, arc.n) / arc.radius)
        return np.array(rows)

    def piece_corners(self) -> np.ndarray:
        """``(pieces,)``: the knot an arc piece rounds, -1 for lines."""
        return np.array([data.corner if kind == "arc" else -1 for kind, data in self._pieces])  # type: ignore[attr-defined]


def _arc(
    corner: np.ndarray,
    y_a: np.ndarray,
    y_b: np.ndarray,
    len_a: float,
    len_b: float,
    deviation: float,
    k: int,
) -> Arc | None:
    """The blend of one corner, or None when it stays sharp (no deviation allowed, no turn, or
    a segment of zero length)."""
    if deviation <= 0 or len_a <= 0 or len_b <= 0:
        return None
    cos_a = float(np.clip(y_a @ y_b, -1.0, 1.0))
    angle = float(np.arccos(cos_a))
    if angle < STRAIGHT or angle > np.pi - 1e-6:
        return None
    half = angle / 2
    reach = min(len_a / 2, len_b / 2, deviation / np.tan(half / 2))
    radius = reach / np.tan(half)
    n = y_b - (y_a @ y_b) * y_a  # the part of the outgoing direction across the incoming one
    n /= np.linalg.norm(n)
    return Arc(k, corner - reach * y_a, float(radius), y_a.copy(), n, angle)
