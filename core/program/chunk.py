"""A program chunk's joint path and its timed motion.

``ChunkPath`` is the geometric joint path of one rest-to-rest stretch (segments joined by blends):
q(s) through its dense joint samples, s in [0, 1] its normalized joint-space arc length (so dq/ds
is continuous across pieces that meet with a continuous tangent), a C2 cubic spline
(``core.program.geometry.smooth``). It implements ``core.timing.joint_path.JoinedPath``: any
path timing law of ``core.timing.TIMING_LAWS`` times it; its breakpoints are the spline's knots
(where d3q/ds3 steps: a grid that holds them sees a tight blend's curvature, which lies between
them) and the junctions of its pieces (where the limits may change: each segment has its own
scales and tool limits), also given as its joins. With ``reversals``, a sample where the path turns back
(consecutive steps more than 90 degrees apart: a blend between a line and its reverse goes straight
down and back up) ends one spline and starts the next, so dq/ds steps there and a law that keeps
every limit everywhere stops there (``core.timing.path_grid.stops``); one spline through it would
turn in a loop of micrometres at a crawl.

``ChunkTiming`` is the chunk timed by such a law: ``sample(t)`` gives q, q', q'' as the exact
derivatives of q(s(t)) (``core.timing.path_profile.joint_motion``), ``switch_times`` where a
derivative up to the jerk may step (the law's own switches: the program returns a point there),
and ``peaks`` the largest |q'|, |q''|, |q'''| of the motion (a dense grid, refined around its
highest values by golden-section search, so the peak is not under-reported between grid points).
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

from core.program.geometry.smooth import smooth_spline
from core.timing.path_limits import PathLimits
from core.timing.path_profile import PathLaw, Stretched, dense_times, joint_motion
from core.trajectory import Peaks

CHECKS_PER_INTERVAL = 10
"""Grid points per knot interval of the peak search."""
REFINED = 3
"""Highest grid values per joint and quantity refined by golden-section search."""
_GOLDEN = 0.5 * (np.sqrt(5.0) - 1.0)
_GOLDEN_STEPS = 30


class ChunkPath:
    """q(s) for s in [0, 1] through ``q`` ``(K, dof)`` (at least two distinct samples): see the
    module docstring. ``knots``: the samples' s ``(K,)``; ``junctions``: indices of the samples
    where one piece ends and the next begins (default none); ``reversals``: split the spline where
    the path turns back."""

    length = 1.0

    def __init__(
        self, q: np.ndarray, junctions: np.ndarray | None = None, reversals: bool = False
    ) -> None:
        q = np.asarray(q, dtype=float)
        steps = np.diff(q, axis=0)
        step = np.linalg.norm(steps, axis=1)
        lam = np.concatenate([[0.0], np.cumsum(step)])
        self.knots = lam / lam[-1]
        self.samples = q
        self.dof = int(q.shape[1])
        turns = np.zeros(0, dtype=int)
        if reversals and len(q) > 2:
            turns = np.flatnonzero(np.einsum("ij,ij->i", steps[:-1], steps[1:]) < 0.0) + 1
        ends = np.concatenate([[0], turns, [len(q) - 1]])
        self._splines = [
            smooth_spline(self.knots[a : b + 1], q[a : b + 1]) for a, b in itertools.pairwise(ends)
        ]
        self._cuts = self.knots[turns]
        inner = np.zeros(0) if junctions is None else self.knots[np.asarray(junctions, dtype=int)]
        self._breaks = np.unique(np.concatenate([self.knots, inner, self._cuts]))

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q (order 0) or d^n q / ds^n (order n <= 3) at ``s`` ``(N,)``: ``(N, dof)`` (at a
        reversal: the spline after it)."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
        if not len(self._cuts):
            return np.asarray(self._splines[0](s, order), dtype=float)
        which = np.searchsorted(self._cuts, s, side="right")
        out = np.empty((len(s), self.dof))
        for k, spline in enumerate(self._splines):
            sel = which == k
            if sel.any():
                out[sel] = spline(s[sel], order)
        return out

    def breakpoints(self) -> np.ndarray:
        """The samples' s (the pieces' junctions and the reversals among them): a timing grid
        holds them, so each grid interval lies in one piece and one cubic of the spline (q, dq/ds
        and d2q/ds2 are continuous but at reversals)."""
        return self._breaks.copy()

    def joins(self) -> np.ndarray:
        """The samples' s (the spline's knots: its third derivative steps there)."""
        return self.knots.copy()


@dataclass(frozen=True)
class ChunkTiming:
    """A chunk timed by a path law (see the module docstring).

    Attributes:
        path: The chunk's joint path.
        law: s(t) from 0 to 1, rest to rest.
        knot_times: Time [s] of each of the path's samples ``(K,)``, from 0 to ``duration``.
        limits: The limits the law timed it under (``core.timing.path_limits.PathLimits``), or
            None.
    """

    path: ChunkPath
    law: PathLaw
    knot_times: np.ndarray
    limits: PathLimits | None = None

    @classmethod
    def of(cls, path: ChunkPath, law: PathLaw, limits: PathLimits | None = None) -> ChunkTiming:
        t = np.asarray(law.time_at(path.knots), dtype=float)
        t[0], t[-1] = 0.0, law.duration
        return cls(path, law, t, limits)

    @property
    def duration(self) -> float:
        return float(self.law.duration)

    @property
    def stretch(self) -> float:
        """The uniform stretch the law's dense check applied (1.0: none)."""
        return self.law.stretch if isinstance(self.law, Stretched) else 1.0

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations ``(N, dof)`` at times ``t`` ``(N,)`` [s]."""
        q, qd, qdd = joint_motion(self.path, self.law, np.asarray(t, dtype=float))
        return q, qd, qdd

    def slower(self, factor: float) -> ChunkTiming:
        """The same chunk run ``factor`` (>= 1) times slower."""
        law = self.law
        inner, k = (law.law, law.stretch) if isinstance(law, Stretched) else (law, 1.0)
        return ChunkTiming(
            self.path, Stretched(inner, k * factor), self.knot_times * factor, self.limits
        )

    def switch_times(self) -> np.ndarray:
        """Times [s] inside the chunk where q(t) may not be smooth (the law's switches)."""
        return np.asarray(self.law.switch_times(), dtype=float)

    def ends(self) -> np.ndarray:
        """``(2, dof)``: the first and last joint samples, exactly."""
        return self.path.samples[[0, -1]]

    def peaks(self) -> Peaks:
        """Largest |q'|, |q''|, |q'''| per joint over the chunk (see the module docstring;
        measured once)."""
        return self._peaks

    @functools.cached_property
    def _peaks(self) -> Peaks:
        knots = np.unique(np.concatenate([self.knot_times, self.switch_times()]))
        t = dense_times(knots, CHECKS_PER_INTERVAL)
        eps = 1e-9 * max(self.duration, 1.0)
        t = np.unique(np.concatenate([t, self.switch_times() - eps, self.switch_times() + eps]))
        t = t[(t >= 0.0) & (t <= self.duration)]
        values = np.abs(np.stack(joint_motion(self.path, self.law, t, jerk=True)[1:]))
        velocity, acceleration, jerk = self._refined(t, values)
        return Peaks(velocity, acceleration, jerk)

    def _refined(self, t: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Per order and joint, the grid maximum of ``f`` ``(3, N, dof)`` (the absolute first,
        second and third derivatives at ``t``), raised by a golden-section search between the grid
        neighbours of its ``REFINED`` highest values (all searches at once: one ``joint_motion``
        call per step and side)."""
        n_orders, n, dof = f.shape
        top = np.argsort(f, axis=1)[:, -REFINED:, :]  # (3, R, dof) rows of the highest values
        order = np.broadcast_to(np.arange(n_orders)[:, None, None], top.shape).ravel()
        joint = np.broadcast_to(np.arange(dof)[None, None, :], top.shape).ravel()
        rows = top.ravel()
        a, b = t[np.maximum(rows - 1, 0)], t[np.minimum(rows + 1, n - 1)]

        def value(x: np.ndarray) -> np.ndarray:
            motion = np.stack(joint_motion(self.path, self.law, x, jerk=True)[1:])
            return np.abs(motion[order, np.arange(len(x)), joint])

        c, d = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
        fc, fd = value(c), value(d)
        best = np.maximum(fc, fd)
        for _ in range(_GOLDEN_STEPS):
            left = fc > fd
            b, a = np.where(left, d, b), np.where(left, a, c)
            c, d = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
            fc, fd = value(c), value(d)
            best = np.maximum(best, np.maximum(fc, fd))
        peak = f.max(axis=1)  # (3, dof)
        np.maximum.at(peak, (order, joint), best)
        return peak
