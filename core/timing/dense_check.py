"""The dense check of a path timing between its grid points: every limit's largest value over its
bound in every grid interval, for a profile with constant s'' on each interval.

The check runs on the timing grid with the path's joins added (``JoinedPath.joins``: a C2
spline's knots, where d3q/ds3 jumps and a limit's value may have a kink), so every checked piece is
smooth; each piece is sampled at ``DENSE`` + 1 evenly spaced points (its ends are the grid's one-sided
rows where it ends at a grid point), the peak between samples is estimated by a parabola, and
peaks within ``NEAR`` of the bound are found to ~1e-13 (``core.timing.interval_peaks``). The rows of
every sample are evaluated once (``Check``); only s'^2 and s'' change between rounds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.timing.interval_peaks import refine_peaks, sampled_peaks
from core.timing.joint_path import JoinedPath, JointPath
from core.timing.path_constraints import PathLimits, Rows
from core.timing.path_grid import sample_path

DENSE = 4
"""Samples at fractions 0, 1/4, ..., 1 of every checked piece."""
NEAR = 1e-7
"""Sampled peaks within this of their bound are found exactly."""


def values(rows: Rows, u: np.ndarray, x: np.ndarray) -> np.ndarray:
    """|A u + B x + C| of ``rows`` ``(K, m)`` at ``u``, ``x`` ``(K,)``."""
    return np.abs(rows.A * u[:, None] + rows.B * x[:, None] + rows.C)


def _take(rows: Rows, mask: np.ndarray) -> Rows:
    return Rows(rows.A[mask], rows.B[mask], rows.C[mask])


def _stack(a: Rows, b: Rows, take_b: np.ndarray, index: np.ndarray) -> Rows:
    """Rows of ``a`` (aligned with ``take_b``) where ``take_b`` is False, else ``b[index]``."""
    pick = take_b[:, None]
    return Rows(*(np.where(pick, getattr(b, f)[index], getattr(a, f)) for f in ("A", "B", "C")))


@dataclass(frozen=True)
class Check:
    """The checked pieces: ``parent`` ``(P,)`` grid interval of each, its fractions ``lo``,
    ``hi`` of that interval, and the rows at its samples: ``first``, ``last`` ``(P, m)``,
    ``inner`` ``(P * (DENSE - 1), m)``."""

    parent: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    first: Rows
    last: Rows
    inner: Rows

    @classmethod
    def build(
        cls, path: JointPath, limits: PathLimits, s: np.ndarray, start: Rows, end: Rows
    ) -> Check:
        """The pieces of grid ``s`` ``(N + 1,)`` cut at the path's joins; ``start``, ``end``: the
        grid intervals' one-sided rows at their ends."""
        joins = np.zeros(0)
        if isinstance(path, JoinedPath):
            joins = np.asarray(path.joins(), dtype=float)
            joins = joins[(joins > s[0]) & (joins < s[-1]) & ~np.isin(joins, s)]
        cuts = np.union1d(s, joins)
        parent = np.clip(np.searchsorted(s, cuts[:-1], side="right") - 1, 0, len(s) - 2)
        d = np.diff(s)[parent]
        lo, hi = (cuts[:-1] - s[parent]) / d, (cuts[1:] - s[parent]) / d
        at_start = np.isin(cuts[:-1], s)
        at_end = np.isin(cuts[1:], s)
        join_rows = limits.rows(*sample_path(path, joins)) if joins.size else start
        where = np.searchsorted(joins, cuts)  # index of each cut among the joins
        first = _stack(
            Rows(*(getattr(start, f)[parent] for f in ("A", "B", "C"))),
            join_rows,
            ~at_start,
            np.minimum(where[:-1], max(joins.size - 1, 0)),
        )
        last = _stack(
            Rows(*(getattr(end, f)[parent] for f in ("A", "B", "C"))),
            join_rows,
            ~at_end,
            np.minimum(where[1:], max(joins.size - 1, 0)),
        )
        f = np.arange(1, DENSE) / DENSE
        frac = lo[:, None] + (hi - lo)[:, None] * f
        inner = limits.rows(*sample_path(path, (s[parent][:, None] + d[:, None] * frac).ravel()))
        return cls(parent, lo, hi, first, last, inner)

    def peaks(
        self,
        path: JointPath,
        limits: PathLimits,
        s: np.ndarray,
        x: np.ndarray,
        h: np.ndarray,
        before: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """The largest value over bound ``h`` of every row in every grid interval ``(N, m)`` for
        s'^2 = ``x`` ``(N + 1,)`` on grid ``s`` (s'' constant on each interval). ``before``: an
        earlier call's ``(x, peaks)``: intervals whose ends kept their x keep their peaks."""
        if before is not None:
            x_old, peak_old = before
            moved = (x[:-1] != x_old[:-1]) | (x[1:] != x_old[1:])
            if not moved.all():
                out = peak_old.copy()
                keep = moved[self.parent]
                if keep.any():
                    part = Check(self.parent[keep], self.lo[keep], self.hi[keep],
                                 _take(self.first, keep), _take(self.last, keep),
                                 _take(self.inner, np.repeat(keep, DENSE - 1)))  # fmt: skip
                    fresh = part.peaks(path, limits, s, x, h)
                    out[moved] = fresh[moved]
                return out
        d = np.diff(s)
        u = np.diff(x) / (2.0 * d)
        p, m = len(self.parent), len(h)
        k = self.parent
        f = self.lo[:, None] + (self.hi - self.lo)[:, None] * (np.arange(DENSE + 1) / DENSE)
        xs = x[k][:, None] + 2.0 * d[k][:, None] * u[k][:, None] * f
        ratios = np.empty((p, DENSE + 1, m))
        ratios[:, 0] = values(self.first, u[k], xs[:, 0]) / h
        ratios[:, -1] = values(self.last, u[k], xs[:, -1]) / h
        inner = values(self.inner, np.repeat(u[k], DENSE - 1), xs[:, 1:-1].ravel()) / h
        ratios[:, 1:-1] = inner.reshape(p, DENSE - 1, m)
        peak, where = sampled_peaks(ratios)
        near = (peak > 1.0 - NEAR) & (where > 0.0) & (where < 1.0)
        if near.any():
            i, r = np.nonzero(near)

            def evaluate(c: np.ndarray, frac: np.ndarray, row: np.ndarray) -> np.ndarray:
                j = k[c]
                g = self.lo[c] + (self.hi[c] - self.lo[c]) * frac  # fraction of the grid interval
                at = s[j] + g * d[j]
                vals = values(
                    limits.rows(*sample_path(path, at)), u[j], x[j] + 2.0 * g * d[j] * u[j]
                )
                return vals[np.arange(len(c)), row] / h[row]

            peak[i, r] = np.maximum(
                peak[i, r], refine_peaks(evaluate, i, r, where[i, r], DENSE + 1)
            )
        out = np.zeros((len(d), m))
        np.maximum.at(out, k, peak)
        return out
