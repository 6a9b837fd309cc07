"""A program chunk's timing inputs and result, shared by the two chunk timings.

``ChunkInput`` is one rest-to-rest stretch (dense joint samples, tool poses, scaled limits);
``ChunkTiming`` its timed law. ``core.program.timing.time_chunk`` (time-optimal, quintic s(t)) and
``core.program.s_curve.s_curve_chunk`` (jerk-limited s(t)) both produce it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from core.trajectory import Peaks

ACCELERATION_SHARE = 0.5
CHECKS_PER_INTERVAL = 10
CAP_MARGIN = 0.98
"""Caps are applied this much tightened: the spline through the timed samples may overshoot a bit."""
TINY = 1e-12


@dataclass(frozen=True)
class ChunkInput:
    """Samples of a chunk's path.

    Attributes:
        q: Joint positions (K, dof).
        T: Tool poses (K, 4, 4).
        v_max: Joint velocity limits (K, dof) [rad/s] at each sample (scaled per segment).
        a_max: Joint acceleration limits (K, dof) [rad/s^2].
        tool_speed: Linear and angular tool speed limits (K, 2) [m/s, rad/s] (inf: none).
        tool_acceleration: Linear and angular tool acceleration limits (K, 2) (inf: none).
        jerk: Tool jerk limits [m/s^3, rad/s^3] of an S-curve chunk (``_s_curve``), else None.
    """

    q: np.ndarray
    T: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray
    tool_speed: np.ndarray
    tool_acceleration: np.ndarray
    jerk: tuple[float, float] | None = None


@dataclass(frozen=True)
class ChunkTiming:
    """The timed chunk: ``sample(t)`` for t in [0, duration].

    Attributes:
        knot_times: Time [s] of each input sample (K,), from 0 to ``duration``.
        duration: Length of the chunk [s].
        stretch: Factor the time-optimal timing was stretched by after the dense check (>= 1).
        law: s(tau) in the unstretched time tau = t / stretch (``law(tau, order)``): a quintic
            spline, or an ``SCurveTiming``.
        path: q(s), a C2 cubic spline through the samples.
    """

    knot_times: np.ndarray
    duration: float
    stretch: float
    law: Callable[..., np.ndarray]
    path: CubicSpline

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations (N, dof) at times ``t`` (N,) [s]."""
        tau = np.asarray(t, dtype=float) / self.stretch
        return evaluate(self.law, self.path, tau, self.duration / self.stretch, self.stretch)

    def peaks(self) -> Peaks:
        """Largest speed, acceleration and jerk per joint of the analytic q(t) = P(s(t)), over a
        dense grid (``CHECKS_PER_INTERVAL`` per knot interval). The jerk is
        P3 s'^3 + 3 P2 s' s'' + P1 s''' (Pn: n-th derivative of the path spline); P3 is constant
        on each cubic piece and steps at its knots, so both neighbouring pieces' values count."""
        k, end = self.stretch, self.duration / self.stretch
        t = self.knot_times / k
        frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
        tau = np.concatenate([(t[:-1, None] + np.diff(t)[:, None] * frac).ravel(), [end]])
        _, vel, acc = evaluate(self.law, self.path, tau, end, k)
        s = np.clip(self.law(tau), 0.0, 1.0)
        sd, sdd, sddd = (self.law(tau, n) / k**n for n in (1, 2, 3))
        d1, d2 = self.path(s, 1), self.path(s, 2)
        x = self.path.x
        jerk = np.zeros(vel.shape[1])
        for back in (0, 1):  # this cubic piece and the previous one
            piece = np.clip(np.searchsorted(x, s, side="right") - 1 - back, 0, len(x) - 2)
            d3 = 6.0 * self.path.c[0, piece]
            j = d3 * (sd**3)[:, None] + 3.0 * d2 * (sd * sdd)[:, None] + d1 * sddd[:, None]
            jerk = np.maximum(jerk, np.abs(j).max(axis=0))
        return Peaks(np.abs(vel).max(axis=0), np.abs(acc).max(axis=0), jerk)


def evaluate(
    law: Callable[..., np.ndarray],
    path: CubicSpline,
    tau: np.ndarray,
    end: float,
    k: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities, accelerations (N, dof) at unstretched times ``tau`` (clipped to
    [0, ``end``]) of a timing stretched by ``k`` (s' divided by k, s'' by k^2)."""
    tau = np.clip(tau, 0.0, end)
    s = np.clip(law(tau), 0.0, 1.0)
    sd, sdd = law(tau, 1) / k, law(tau, 2) / k**2
    d1 = path(s, 1)
    return path(s), d1 * sd[:, None], path(s, 2) * (sd**2)[:, None] + d1 * sdd[:, None]


def norm_rows(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=1)
