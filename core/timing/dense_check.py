"""The dense check of a path timing between its grid points: every limit's largest value over its
bound in every grid interval, and where it is, for a profile with constant s'' on each interval.

The check runs on the timing grid with the path's joins added (``JoinedPath.joins``: a C2
spline's knots, where d3q/ds3 jumps and a limit's value may have a kink), so every checked piece is
smooth; each piece is sampled at ``DENSE`` + 1 evenly spaced points (its ends are the grid's
one-sided rows where it ends at a grid point), the peak between samples is estimated by a parabola
(only where the largest sample exceeds ``SCREEN``: below it no parabola through the samples reaches
0.99), and peaks within ``NEAR`` of the bound are found to ~1e-13
(``core.timing.interval_peaks``). The rows of every sample are evaluated once (``Check``); only
s'^2 and s'' change between rounds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from core.timing.interval_peaks import is_parabola, parabola_peak, refine_peaks_at
from core.timing.joint_path import JoinedPath, JointPath
from core.timing.path_constraints import PathLimits, Rows
from core.timing.path_grid import NUDGE, sample_path

DENSE = 4
"""Samples at fractions 0, 1/4, ..., 1 of every checked piece."""
NEAR = 1e-7
"""Sampled peaks within this of their bound are found exactly."""
PARTIAL = 0.5
"""Only the intervals whose speeds moved are checked again when they are fewer than this share
(copying their rows costs more than it saves beyond it)."""
SCREEN = 0.88
"""Rows whose samples all stay below this are below 0.99 everywhere on the piece: the parabola
through three non-negative samples peaks at most 1/8 of the middle one above it."""


def values(rows: Rows, u: np.ndarray, x: np.ndarray) -> np.ndarray:
    """|A u + B x + C| of ``rows`` ``(K, m)`` at ``u``, ``x`` ``(K,)``."""
    return np.abs(rows.A * u[:, None] + rows.B * x[:, None] + rows.C)


class Peaks(NamedTuple):
    """Per grid interval and row ``(N, m)``: the largest ``value`` over the bound, and ``at``,
    the fraction of the interval where it is."""

    value: np.ndarray
    at: np.ndarray


@dataclass(frozen=True)
class Check:
    """The checked pieces: ``parent`` ``(P,)`` grid interval of each (non-decreasing), its
    fractions ``lo``, ``hi`` of that interval, and the rows at its ``DENSE + 1`` samples: ``A``,
    ``B`` ``(P, DENSE + 1, m)``, ``C`` likewise or None (no row has a constant term)."""

    parent: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray | None

    @classmethod
    def build(
        cls, path: JointPath, limits: PathLimits, s: np.ndarray, start: Rows, end: Rows
    ) -> Check:
        """The pieces of grid ``s`` ``(N + 1,)`` cut at the path's joins; ``start``, ``end``: the
        grid intervals' one-sided rows at their ends."""
        joins = np.zeros(0)
        if isinstance(path, JoinedPath):
            joins = np.asarray(path.joins(), dtype=float)
            joins = joins[(joins > s[0]) & (joins < s[-1])]
            joins = joins[~_on_grid(s, joins)]
        m = start.A.shape[1]
        if joins.size:
            cuts = np.concatenate([s, joins])
            order = np.argsort(cuts, kind="stable")
            cuts, is_join = cuts[order], order >= len(s)
        else:
            cuts, is_join = s, np.zeros(len(s), dtype=bool)
        grid_index = np.cumsum(~is_join) - 1  # the grid point at or before every cut
        parent = grid_index[:-1]
        d = np.diff(s)[parent]
        lo, hi = (cuts[:-1] - s[parent]) / d, (cuts[1:] - s[parent]) / d
        hi[~is_join[1:]] = 1.0
        f = np.arange(1, DENSE) / DENSE
        inner = (s[parent][:, None] + d[:, None] * (lo[:, None] + (hi - lo)[:, None] * f)).ravel()
        at = np.concatenate([joins, inner])
        rows = limits.rows(*sample_path(path, at))
        p = len(parent)
        join_at = np.cumsum(is_join) - 1  # index among the joins of a join cut
        first, last = np.flatnonzero(is_join[:-1]), np.flatnonzero(is_join[1:])
        constant = bool(np.any(rows.C) or np.any(start.C) or np.any(end.C))
        out = []
        for name in ("A", "B", "C") if constant else ("A", "B"):
            every = getattr(rows, name)
            block = np.empty((p, DENSE + 1, m))
            block[:, 1:-1] = every[joins.size :].reshape(p, DENSE - 1, m)
            block[:, 0] = getattr(start, name)[parent]
            block[:, -1] = getattr(end, name)[parent]
            block[first, 0] = every[join_at[first]]
            block[last, -1] = every[join_at[last + 1]]
            out.append(block)
        c = out[2] if constant else None
        return cls(parent, lo, hi, out[0], out[1], c)

    def subset(self, keep: np.ndarray) -> Check:
        """The pieces where ``keep`` ``(P,)``."""
        c = None if self.C is None else self.C[keep]
        return Check(self.parent[keep], self.lo[keep], self.hi[keep], self.A[keep],
                     self.B[keep], c)  # fmt: skip

    def peaks(
        self,
        path: JointPath,
        limits: PathLimits,
        s: np.ndarray,
        x: np.ndarray,
        h: np.ndarray,
        before: tuple[np.ndarray, Peaks] | None = None,
    ) -> Peaks:
        """The largest value over bound ``h`` of every row in every grid interval, and where,
        for s'^2 = ``x`` ``(N + 1,)`` on grid ``s`` (s'' constant on each interval). ``before``:
        an earlier call's ``(x, peaks)``: intervals whose ends kept their x keep their peaks."""
        if before is not None:
            x_old, old = before
            moved = (x[:-1] != x_old[:-1]) | (x[1:] != x_old[1:])
            if moved.mean() < PARTIAL:
                value, at = old.value.copy(), old.at.copy()
                keep = moved[self.parent]
                if keep.any():
                    fresh = self.subset(keep)._peaks(path, limits, s, x, h)
                    value[moved], at[moved] = fresh.value[moved], fresh.at[moved]
                return Peaks(value, at)
        return self._peaks(path, limits, s, x, h)

    def _peaks(
        self, path: JointPath, limits: PathLimits, s: np.ndarray, x: np.ndarray, h: np.ndarray
    ) -> Peaks:
        d = np.diff(s)
        u = np.diff(x) / (2.0 * d)
        k = self.parent
        f = self.lo[:, None] + (self.hi - self.lo)[:, None] * (np.arange(DENSE + 1) / DENSE)
        uk = u[k]
        xs = x[k][:, None] + (2.0 * d[k] * uk)[:, None] * f
        total = self.A * uk[:, None, None] + self.B * xs[:, :, None]
        if self.C is not None:
            total += self.C
        ratios = np.abs(total, out=total)
        ratios /= h
        peak = ratios[:, 0].copy()
        for j in range(1, DENSE + 1):
            np.maximum(peak, ratios[:, j], out=peak)
        where = np.zeros_like(peak)
        i, r = np.nonzero(peak > SCREEN)
        if i.size:
            samples = ratios[i, :, r]  # (C, DENSE + 1)
            t = samples.argmax(axis=1)
            c = np.clip(t, 1, DENSE - 1)
            pick = np.arange(len(i))
            v0, v1, v2 = samples[pick, c - 1], samples[pick, c], samples[pick, c + 1]
            est, w = parabola_peak(v0, v1, v2, peak[i, r], t, DENSE + 1)
            near = (est > 1.0 - NEAR) & (w > 0.0) & (w < 1.0) & ~is_parabola(samples, c)
            if near.any():
                est[near], w[near] = self._refine(path, limits, s, x, h, i[near], r[near], w[near])
            peak[i, r], where[i, r] = est, w
        return self._per_interval(
            len(d), peak, self.lo[:, None] + (self.hi - self.lo)[:, None] * where
        )

    def _refine(
        self, path: JointPath, limits: PathLimits, s: np.ndarray, x: np.ndarray, h: np.ndarray,
        i: np.ndarray, r: np.ndarray, w: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """Peaks of rows ``r`` on pieces ``i`` near piece fractions ``w``, found exactly."""
        d = np.diff(s)
        u = np.diff(x) / (2.0 * d)
        k = self.parent

        def evaluate(c: np.ndarray, frac: np.ndarray, row: np.ndarray) -> np.ndarray:
            j = k[c]
            g = self.lo[c] + (self.hi[c] - self.lo[c]) * frac  # fraction of the grid interval
            g = np.clip(g, NUDGE, 1.0 - NUDGE)  # a grid point may be a breakpoint: stay inside
            rows = limits.rows(*sample_path(path, s[j] + g * d[j]))
            pick = np.arange(len(c))
            v = rows.A[pick, row] * u[j] + rows.B[pick, row] * (x[j] + 2.0 * g * d[j] * u[j])
            return np.abs(v + rows.C[pick, row]) / h[row]

        return refine_peaks_at(evaluate, i, r, w, DENSE + 1)

    def _per_interval(self, n: int, peak: np.ndarray, at: np.ndarray) -> Peaks:
        """Piece values ``(P, m)`` reduced to their grid intervals (``n`` of them)."""
        k = self.parent
        first = np.flatnonzero(np.concatenate([[True], k[1:] != k[:-1]]))
        if len(first) == len(k):  # one piece per interval
            value, where = peak, at
        else:
            value = np.maximum.reduceat(peak, first, axis=0)
            group = np.cumsum(np.concatenate([[True], k[1:] != k[:-1]])) - 1
            piece = np.where(peak == value[group], np.arange(len(k))[:, None], -1)
            where = np.take_along_axis(at, np.maximum.reduceat(piece, first, axis=0), axis=0)
        if len(first) == n:  # every interval
            return Peaks(value, where)
        out_v, out_at = np.zeros((n, peak.shape[1])), np.zeros((n, peak.shape[1]))
        out_v[k[first]], out_at[k[first]] = value, where
        return Peaks(out_v, out_at)


def _on_grid(s: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``points`` that are (exactly) grid points of ``s``."""
    i = np.clip(np.searchsorted(s, points), 0, len(s) - 1)
    return s[i] == points
