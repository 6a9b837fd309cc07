"""Timing a collision-free motion's geometric path: s(t) along it, sampled into joint motion.

``PathMotion`` samples q(t) = path(s(t)) with the exact derivatives q' = q_s s' and
q'' = q_s s'' + q_ss s'^2 for any ``core.timing.joint_path.JointPath`` and any s(t) profile: the
timing law is the one line of ``time_path``, meant to become the time-optimal law of
``core.timing.topp`` once it exists. Until then ``grid_timing`` is the phase-plane law of
``core.timing.speed_limited.GridTiming`` with caps that make every joint limit hold exactly on a
``BlendedPath``: on each piece |q_s,j| <= v_j (``speed_bounds``) and |q_ss,j| <= k_j
(``curvature_bounds``, arcs only); the speed cap is ``min_j vmax_j / v_j``, on arcs also
``sqrt(min_j amax_j / (2 k_j))`` (the centripetal part takes at most half of each acceleration
limit), and |s''| <= ``min_j amax_j / v_j`` on lines, half that on arcs. The grid holds every
breakpoint and s'^2 is linear in s on each grid interval, so the caps hold between grid points too.
At a sharp corner (``BlendedPath.stops``) the cap is 0: the motion comes to rest there.

``jerk_limited`` keeps jerk limits: the straight segments through the knots, each a rest-to-rest
S-curve (``core.timing.s_curve.SCurveTiming``, Ruckig) along its own line, the joints' velocity,
acceleration and jerk limits divided by the segment's direction components; the path is exactly
the polyline that was certified.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from core.motion.path import BlendedPath
from core.timing.s_curve import SCurveTiming
from core.timing.speed_limited import GridTiming

TIMINGS = ("time_optimal", "jerk_limited")
"""The timings a collision-free motion takes (``time_path``; ``StopAndGo``)."""
GRID_SPACING = 0.01
"""[rad] Longest interval of the timing grid along the path."""
MAX_GRID = 20_000
"""Most grid points (the spacing grows on long paths)."""


class PathLaw(Protocol):
    """s(t) from 0 to ``length`` of a path at rest at both ends; ``time_at`` inverts it."""

    duration: float

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray: ...

    def time_at(self, s: np.ndarray) -> np.ndarray: ...


class Motion(Protocol):
    """A timed joint motion: ``duration`` [s], ``sample(times)`` -> q, q', q'', and the instants
    [s] where it stops at a corner (``stops``)."""

    duration: float

    def sample(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def stops(self) -> np.ndarray: ...


class PathMotion:
    """Joint motion along ``path`` timed by ``law``: ``sample(times)`` -> q, q', q''."""

    def __init__(self, path: BlendedPath, law: PathLaw) -> None:
        self.path, self.law = path, law
        self.duration = float(law.duration)

    def stops(self) -> np.ndarray:
        return np.asarray(self.law.time_at(self.path.stops()), dtype=float)

    def sample(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, sd, sdd = (np.asarray(self.law(times, k), dtype=float) for k in range(3))
        q_s = self.path(s, 1)
        return (
            self.path(s),
            q_s * sd[:, None],
            q_s * sdd[:, None] + self.path(s, 2) * (sd**2)[:, None],
        )


class _Scaled:
    """A law on u in [0, 1] stretched to s = length u."""

    def __init__(self, law: GridTiming, length: float) -> None:
        self.law, self.length = law, float(length)
        self.duration = float(law.duration)

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        return self.length * np.asarray(self.law(t, order), dtype=float)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        return self.law.time_at(np.asarray(s, dtype=float) / self.length)


def grid_timing(path: BlendedPath, velocity: np.ndarray, acceleration: np.ndarray) -> PathLaw:
    """The fastest s(t) under the exact joint velocity/acceleration caps of ``path`` (above)."""
    L = path.length
    starts = path.breakpoints()
    speed, curv = path.speed_bounds(), path.curvature_bounds()
    arc = curv.max(axis=1) > 0
    with np.errstate(divide="ignore"):
        v_cap = np.min(np.where(speed > 0, velocity / speed, np.inf), axis=1)
        a_cap = np.min(np.where(speed > 0, acceleration / speed, np.inf), axis=1)
        c_cap = np.sqrt(np.min(np.where(curv > 0, acceleration / (2 * curv), np.inf), axis=1))
    v_cap = np.minimum(v_cap, c_cap)
    a_cap = np.where(arc, a_cap / 2, a_cap)
    spacing = max(GRID_SPACING, L / MAX_GRID)
    grid, piece = [np.zeros(1)], [np.zeros(0, dtype=int)]
    for k in range(len(starts) - 1):
        n = max(int(np.ceil((starts[k + 1] - starts[k]) / spacing)), 1)
        grid.append(np.linspace(starts[k], starts[k + 1], n + 1)[1:])
        piece.append(np.full(n, k))
    s, owner = np.concatenate(grid), np.concatenate(piece)  # owner: piece of each interval
    cap = np.minimum(np.r_[v_cap[owner], np.inf], np.r_[np.inf, v_cap[owner]])
    stops = path.stops()
    if len(stops):  # sharp corners: at rest there (they are breakpoints, so on the grid)
        cap[np.clip(np.searchsorted(s, stops - 1e-12), 0, len(s) - 1)] = 0.0
    a = np.where(np.isfinite(a_cap[owner]), a_cap[owner], 1e12)
    return _Scaled(GridTiming(s / L, cap / L, a / L), L)


def time_path(path: BlendedPath, velocity: np.ndarray, acceleration: np.ndarray) -> PathMotion:
    """The timed motion along ``path`` (the one place the timing law is chosen)."""
    return PathMotion(path, grid_timing(path, velocity, acceleration))


class StopAndGo:
    """Rest-to-rest jerk-limited S-curves along the straight segments through ``knots``."""

    def __init__(
        self, knots: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, jerk: np.ndarray
    ) -> None:
        self.knots = np.asarray(knots, dtype=float)
        steps = np.diff(self.knots, axis=0)
        keep = np.linalg.norm(steps, axis=1) > 0
        self.knots = np.vstack([self.knots[:1], self.knots[1:][keep]])
        steps = steps[keep]
        self.steps = steps
        self.laws = []
        for d in steps:
            moving = np.abs(d) > 0
            bound = [float(np.min(lim[moving] / np.abs(d[moving])))
                     for lim in (velocity, acceleration, jerk)]  # fmt: skip
            self.laws.append(SCurveTiming(max_velocity=bound[0], max_acceleration=bound[1],
                                          max_jerk=bound[2]))  # fmt: skip
        self.starts = np.concatenate([[0.0], np.cumsum([law.duration for law in self.laws])])
        self.duration = float(self.starts[-1])

    def stops(self) -> np.ndarray:
        return self.starts[1:-1].copy()

    def sample(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        times = np.asarray(times, dtype=float)
        n, dof = len(times), self.knots.shape[1]
        q, qd, qdd = np.empty((n, dof)), np.zeros((n, dof)), np.zeros((n, dof))
        if not self.laws:
            q[:] = self.knots[0]
            return q, qd, qdd
        k = np.clip(np.searchsorted(self.starts, times, side="right") - 1, 0, len(self.laws) - 1)
        for i in np.unique(k):
            m = k == i
            t = times[m] - self.starts[i]
            law, d = self.laws[i], self.steps[i]
            q[m] = self.knots[i] + law(t)[:, None] * d
            qd[m] = law(t, 1)[:, None] * d
            qdd[m] = law(t, 2)[:, None] * d
        return q, qd, qdd
