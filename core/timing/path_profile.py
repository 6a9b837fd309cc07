"""A timed joint path: s(t) laws on a ``JointPath``, their uniform stretch, and q(s(t)).

``SplineLaw`` is s(t) as a quintic spline through a timed grid (C4, rest at both ends), with an
exact inverse ``time_at``. ``Stretched`` is a law run slower by a factor k (s' / k, s'' / k^2,
s''' / k^3): how a path law that overshoots a limit between its grid points is brought back within
it. ``joint_motion`` is the chain rule of q(t) = q(s(t)) up to the jerk:

    q' = q_s s',  q'' = q_ss s'^2 + q_s s'',  q''' = q_sss s'^3 + 3 q_ss s' s'' + q_s s'''.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from scipy.interpolate import make_interp_spline

from core.timing.joint_path import JointPath

_BISECTIONS = 60


class PathLaw(Protocol):
    """s(t) on [0, duration] [s] with derivatives to order 3 and an inverse."""

    @property
    def duration(self) -> float: ...

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray: ...

    def time_at(self, s: np.ndarray) -> np.ndarray: ...

    def switch_times(self) -> np.ndarray:
        """Times [s] inside (0, duration) where a derivative of s(t) up to the third steps (the
        returned points of a program include them, so q(t) is smooth between two of them)."""
        ...


class SplineLaw:
    """s(t) through the timed grid ``(t, s)`` (``(K,)`` each, increasing): a quintic spline with
    zero s' and s'' at both ends (scipy ``make_interp_spline``, k = 5)."""

    def __init__(self, t: np.ndarray, s: np.ndarray) -> None:
        bc = ([(1, 0.0), (2, 0.0)], [(1, 0.0), (2, 0.0)])
        self.t, self.s = np.asarray(t, dtype=float), np.asarray(s, dtype=float)
        self.spline = make_interp_spline(self.t, self.s, k=5, bc_type=bc)
        self.duration = float(self.t[-1])
        self.end = float(self.s[-1])

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s (order 0, clipped to [0, end]) or its derivative of that order at ``t`` [s]."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        out = np.asarray(self.spline(t, order), dtype=float)
        return np.clip(out, 0.0, self.end) if order == 0 else out

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] where the law reaches ``s``: exact at the grid, bisection between."""
        return invert(self, self.t, self.s, s)

    def switch_times(self) -> np.ndarray:
        """None: a quintic spline is C4 (its fifth derivative steps, which no jerk sees)."""
        return np.zeros(0)


def invert(law: PathLaw, t_grid: np.ndarray, s_grid: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Times where ``law`` (non-decreasing) reaches ``s``, bracketed by its grid ``(t, s)``."""
    s = np.asarray(s, dtype=float)
    i = np.clip(np.searchsorted(s_grid, s, side="right") - 1, 0, len(s_grid) - 2)
    lo, hi = t_grid[i].astype(float), t_grid[i + 1].astype(float)
    exact = s == s_grid[i]
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        below = law(mid) < s
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return np.where(exact, t_grid[i], 0.5 * (lo + hi))


class Stretched:
    """``law`` run ``stretch`` (>= 1) times slower: s(t) = law(t / stretch)."""

    def __init__(self, law: PathLaw, stretch: float = 1.0) -> None:
        self.law, self.stretch = law, float(stretch)
        self.duration = float(law.duration) * self.stretch

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        return np.asarray(self.law(np.asarray(t, dtype=float) / self.stretch, order)) / (
            self.stretch**order
        )

    def time_at(self, s: np.ndarray) -> np.ndarray:
        return self.stretch * np.asarray(self.law.time_at(s), dtype=float)

    def switch_times(self) -> np.ndarray:
        return self.stretch * np.asarray(self.law.switch_times(), dtype=float)


def joint_motion(
    path: JointPath, law: PathLaw, t: np.ndarray, jerk: bool = False
) -> tuple[np.ndarray, ...]:
    """q, q', q'' (and q''' with ``jerk``) of q(s(t)) at ``t`` ``(N,)`` [s], each ``(N, dof)``
    (the chain rule of the module docstring; ``path`` needs order 3 for the jerk)."""
    t = np.clip(np.asarray(t, dtype=float), 0.0, law.duration)
    s = law(t)
    sd, sdd = law(t, 1), law(t, 2)
    d1, d2 = path(s, 1), path(s, 2)
    q = path(s)
    qd = d1 * sd[:, None]
    qdd = d2 * (sd**2)[:, None] + d1 * sdd[:, None]
    if not jerk:
        return q, qd, qdd
    d3, sddd = path(s, 3), law(t, 3)
    qddd = d3 * (sd**3)[:, None] + 3.0 * d2 * (sd * sdd)[:, None] + d1 * sddd[:, None]
    return q, qd, qdd, qddd


def dense_times(knots: np.ndarray, per_interval: int) -> np.ndarray:
    """``per_interval`` evenly spaced times in each interval of ``knots`` ``(K,)``, the last
    knot included."""
    frac = np.arange(per_interval) / per_interval
    inner = (knots[:-1, None] + np.diff(knots)[:, None] * frac).ravel()
    return np.concatenate([inner, knots[-1:]])


def stretch_for(ratios: tuple[float, ...]) -> float:
    """The uniform stretch that brings peaks ``ratios`` (velocity, acceleration, jerk over their
    limits) within them: max(1, r_v, sqrt(r_a), cbrt(r_j)), a hair more; exactly 1 when within."""
    k = 1.0
    for order, r in enumerate(ratios, start=1):
        k = max(k, float(r) ** (1.0 / order))
    k *= 1.0 + 1e-9
    return 1.0 if k <= 1.0 + 2e-9 else k
