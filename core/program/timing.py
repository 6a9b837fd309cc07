"""Timing of one rest-to-rest stretch of a program (a chunk: segments joined by blends).

The chunk's joint path is given by dense samples ``q_k`` (IK along lines and arcs, joint lines,
blends). It is parameterized by its joint-space arc length (normalized to s in [0, 1]), so dq/ds
is continuous across pieces that meet with a continuous tangent. Then:

1. Time-optimal s(t) (``core.path_timing.GridTiming``, the phase-plane forward/backward pass)
   under, at each sample: |dq/ds| s' <= v_max (the segment's scaled joint velocity limits), half of
   each joint's acceleration limit for the curvature term |d2q/ds2| s'^2 (another cap on s') and
   half for |dq/ds| |s''|, and the tool's linear/angular speed and acceleration limits on LIN/CIRC
   samples. A sharp corner (large d2q/ds2) slows the motion; a shallow one barely.
2. A quintic spline s(t) through the timed grid (scipy ``make_interp_spline``, k = 5, zero s' and
   s'' at both ends) and the path q(s) as a C2 cubic spline through the samples: q(t) = q(s(t)) has
   q, q', q'' continuous everywhere, stays on the sampled path's geometry, and is at rest at the
   chunk's ends, so chunks join with continuous q'' too.
3. A dense check (``CHECKS_PER_INTERVAL`` per knot interval) of joint velocity and acceleration
   against the limits; over them, time is stretched uniformly by the smallest factor that holds
   (velocities scale by 1/k, accelerations by 1/k^2).

An S-curve chunk (``ChunkInput.jerk`` set, ``_s_curve``) replaces steps 1-2 by one
``core.timing.s_curve.SCurveTiming`` s(t) (continuous s'', bounded jerk of s) and adds the tool's
linear jerk to the dense check (jerk scales by 1/k^3).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, make_interp_spline

from core.line import rotvecs
from core.path_timing import GridTiming
from core.timing.s_curve import SCurveTiming
from core.trajectory import Peaks

ACCELERATION_SHARE = 0.5
CHECKS_PER_INTERVAL = 10
CAP_MARGIN = 0.98
"""Caps are applied this much tightened: the spline through the timed samples may overshoot a bit."""
_TINY = 1e-12


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
        return _evaluate(self.law, self.path, tau, self.duration / self.stretch, self.stretch)

    def peaks(self) -> Peaks:
        """Largest speed, acceleration and jerk per joint of the analytic q(t) = P(s(t)), over a
        dense grid (``CHECKS_PER_INTERVAL`` per knot interval). The jerk is
        P3 s'^3 + 3 P2 s' s'' + P1 s''' (Pn: n-th derivative of the path spline); P3 is constant
        on each cubic piece and steps at its knots, so both neighbouring pieces' values count."""
        k, end = self.stretch, self.duration / self.stretch
        t = self.knot_times / k
        frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
        tau = np.concatenate([(t[:-1, None] + np.diff(t)[:, None] * frac).ravel(), [end]])
        _, vel, acc = _evaluate(self.law, self.path, tau, end, k)
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


def _evaluate(
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


def _norm_rows(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=1)


def time_chunk(c: ChunkInput) -> ChunkTiming:
    """Time the chunk (see the module docstring). ``c.q`` needs two distinct samples or more."""
    q = c.q
    step = _norm_rows(np.diff(q, axis=0))
    lam = np.concatenate([[0.0], np.cumsum(step)])
    s = lam / lam[-1]
    path = CubicSpline(s, q)
    dq, d2q = path(s, 1), path(s, 2)
    ds = np.diff(s)
    # Tool speed per unit s: linear from a spline of positions, angular by finite differences.
    dp = _norm_rows(CubicSpline(s, c.T[:, :3, 3])(s, 1))
    rel = rotvecs(c.T[1:, :3, :3] @ np.swapaxes(c.T[:-1, :3, :3], 1, 2))
    w_int = _norm_rows(rel) / ds
    dw = np.maximum(np.concatenate([w_int[:1], w_int]), np.concatenate([w_int, w_int[-1:]]))
    with np.errstate(divide="ignore", invalid="ignore"):
        caps = [
            np.min(np.where(np.abs(dq) > _TINY, c.v_max / np.abs(dq), np.inf), axis=1),
            np.min(
                np.where(
                    np.abs(d2q) > _TINY,
                    np.sqrt(ACCELERATION_SHARE * c.a_max / np.abs(d2q)),
                    np.inf,
                ),
                axis=1,
            ),
            np.where(dp > _TINY, c.tool_speed[:, 0] / dp, np.inf),
            np.where(dw > _TINY, c.tool_speed[:, 1] / dw, np.inf),
        ]
        acc = [
            np.min(
                np.where(
                    np.abs(dq) > _TINY, (1 - ACCELERATION_SHARE) * c.a_max / np.abs(dq), np.inf
                ),
                axis=1,
            ),
            np.where(dp > _TINY, c.tool_acceleration[:, 0] / dp, np.inf),
            np.where(dw > _TINY, c.tool_acceleration[:, 1] / dw, np.inf),
        ]
    cap = CAP_MARGIN * np.minimum.reduce(caps)
    acc_s = CAP_MARGIN * np.minimum.reduce(acc)
    acc_int = np.minimum(acc_s[:-1], acc_s[1:])
    acc_int = np.where(np.isfinite(acc_int), acc_int, 1e6)
    if c.jerk is not None:
        return _s_curve(c, s, path, cap, acc_int, dp, dw)
    timing = GridTiming(s, np.minimum(cap, 1e9), acc_int)
    t = timing.t
    bc = ([(1, 0.0), (2, 0.0)], [(1, 0.0), (2, 0.0)])
    law = make_interp_spline(t, s, k=5, bc_type=bc)
    # Dense check of the limits between the knots.
    frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
    dense = (t[:-1, None] + np.diff(t)[:, None] * frac).ravel()
    _, vel, accel = _evaluate(law, path, dense, float(t[-1]))
    v_lim = np.repeat(np.minimum(c.v_max[:-1], c.v_max[1:]), CHECKS_PER_INTERVAL, axis=0)
    a_lim = np.repeat(np.minimum(c.a_max[:-1], c.a_max[1:]), CHECKS_PER_INTERVAL, axis=0)
    ratio_v = float(np.max(np.abs(vel) / v_lim))
    ratio_a = float(np.max(np.abs(accel) / a_lim))
    stretch = max(1.0, ratio_v, np.sqrt(ratio_a)) * (1.0 + 1e-9)
    stretch = 1.0 if stretch <= 1.0 + 2e-9 else stretch
    return ChunkTiming(
        knot_times=t * stretch,
        duration=float(t[-1] * stretch),
        stretch=stretch,
        law=law,
        path=path,
    )


def _s_curve(
    c: ChunkInput,
    s: np.ndarray,
    path: CubicSpline,
    cap: np.ndarray,
    acc_int: np.ndarray,
    dp: np.ndarray,
    dw: np.ndarray,
) -> ChunkTiming:
    """An S-curve chunk: s(t) is one ``SCurveTiming`` (s'' continuous, |s'''| bounded) under the
    chunk's smallest speed cap and path acceleration (conservative, as ``s_curve_limited``), with
    s''' <= the tool jerk limits over the largest tool speed per unit s (``c.jerk``). A dense check
    of the joint velocities and accelerations and of the tool's linear jerk
    P3 s'^3 + 3 P2 s' s'' + P1 s''' (P: a C2 spline of the tool positions) stretches time
    uniformly where needed (jerk scales by 1/k^3)."""
    j_lin, j_ang = c.jerk  # type: ignore[misc]
    bounds = [np.inf]
    if dp.max() > _TINY:
        bounds.append(j_lin / dp.max())
    if dw.max() > _TINY:
        bounds.append(j_ang / dw.max())
    j_max = min(bounds)
    if not np.isfinite(j_max):  # the tool does not move (a pure wrist turn is caught above)
        j_max = 1e6
    law = SCurveTiming(
        max_velocity=float(min(np.min(cap), 1e9)),
        max_acceleration=float(np.min(acc_int)),
        max_jerk=float(j_max),
    )
    end = law.duration
    frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
    knots = np.unique(np.concatenate([law.time_at(s), np.linspace(0.0, end, 201)]))
    dense = np.concatenate([(knots[:-1, None] + np.diff(knots)[:, None] * frac).ravel(), [end]])
    _, vel, accel = _evaluate(law, path, dense, end)
    s_d = np.clip(law(dense), 0.0, 1.0)
    i = np.clip(np.searchsorted(s, s_d, side="right") - 1, 0, len(s) - 2)
    v_lim, a_lim = np.minimum(c.v_max[i], c.v_max[i + 1]), np.minimum(c.a_max[i], c.a_max[i + 1])
    tool = CubicSpline(s, c.T[:, :3, 3])
    sd, sdd, sddd = law(dense, 1), law(dense, 2), law(dense, 3)
    jerk = np.zeros(len(dense))
    for back in (0, 1):  # P3 steps at the knots: both neighbouring pieces
        piece = np.clip(np.searchsorted(s, s_d, side="right") - 1 - back, 0, len(s) - 2)
        vec = (
            6.0 * tool.c[0, piece] * (sd**3)[:, None]
            + 3.0 * tool(s_d, 2) * (sd * sdd)[:, None]
            + tool(s_d, 1) * sddd[:, None]
        )
        jerk = np.maximum(jerk, _norm_rows(vec))
    ratio_v = float(np.max(np.abs(vel) / v_lim))
    ratio_a = float(np.max(np.abs(accel) / a_lim))
    ratio_j = float(jerk.max() / j_lin) if np.isfinite(j_lin) else 0.0
    stretch = max(1.0, ratio_v, np.sqrt(ratio_a), np.cbrt(ratio_j)) * (1.0 + 1e-9)
    stretch = 1.0 if stretch <= 1.0 + 2e-9 else stretch
    t = law.time_at(s)
    t[0], t[-1] = 0.0, end
    return ChunkTiming(
        knot_times=t * stretch,
        duration=float(end * stretch),
        stretch=stretch,
        law=law,
        path=path,
    )
