"""Timing of one rest-to-rest stretch of a program (a chunk: segments joined by blends).

The chunk's joint path is given by dense samples ``q_k`` (IK along lines and arcs, joint lines,
blends). It is parameterized by its joint-space arc length (normalized to s in [0, 1]), so dq/ds
is continuous across pieces that meet with a continuous tangent. Then:

1. Time-optimal s(t) (``core.timing.speed_limited.GridTiming``, the phase-plane forward/backward pass)
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

An S-curve chunk (``ChunkInput.jerk`` set, ``_s_curve``) replaces steps 1-2 by an S-curve law
(continuous s'', bounded jerk of s): ``ShapedSCurve``, a ``core.timing.s_curve.SCurveTiming``
through a smooth speed shape of the caps (lowered where the dense check finds a limit exceeded,
a few rounds), or one ``SCurveTiming`` under the chunk's smallest caps, whichever is shorter; the
dense check adds the tool's linear jerk (jerk scales by 1/k^3).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, make_interp_spline

from core.geometry import so3
from core.timing.s_curve import SCurveTiming
from core.timing.speed_limited import GridTiming
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
    rel = so3.log(c.T[1:, :3, :3] @ np.swapaxes(c.T[:-1, :3, :3], 1, 2))
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


SHAPE_SHARE = 0.5
"""Share of the path acceleration the speed shape of a shaped S-curve may use (the rest is left to
the S-curve's own start and end and to the smoothing)."""
SHAPE_GRID = 2001
"""Points of the uniform s grid on which the speed shape is smoothed and integrated."""
SHAPE_ROUNDS = 6
"""Rounds of lowering the speed shape where the dense check finds it over a limit."""
SHAPE_SMOOTHING = 0.01
"""Width (share of the chunk's s) of the running minimum and of each of the two running means
that smooth the speed shape (bounded jerk where its acceleration switches)."""


class ShapedSCurve:
    """s(t) = h(sigma(t)): an S-curve sigma(t) (Ruckig, from 0 to ``Sigma``, sigma' <= 1) through
    a reparameterization h with h' = g(h), g a smooth speed shape of the path (s' <= g(s) under
    every speed cap, g g' within part of the path acceleration; h is a cubic spline through the
    integral sigma(s) of 1/g). The S-curve sets the start and the end; in between s' follows g.
    ``law(tau, order)`` as ``SCurveTiming``."""

    def __init__(self, u: np.ndarray, g: np.ndarray, acceleration: float, jerk: float) -> None:
        sigma = np.concatenate([[0.0], np.cumsum(np.diff(u) * 2.0 / (g[:-1] + g[1:]))])
        self.h = CubicSpline(sigma, u)
        # A spline through steep data may overshoot: the law is used only where s grows.
        self.monotone = bool(np.min(self.h(sigma, 1)) > 0.0)
        self.curve = SCurveTiming(
            max_velocity=1.0,
            max_acceleration=acceleration / float(sigma[-1]),
            max_jerk=jerk / float(sigma[-1]),
        )
        self.total = float(sigma[-1])
        self.duration = self.curve.duration

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s (order 0) or its time derivative of that order (1 to 3) at times ``t`` [s]: the
        chain rule through h itself (h' = g up to the integration), so the derivatives are
        exactly those of s(t)."""
        t = np.asarray(t, dtype=float)
        x = self.total * self.curve(t)  # sigma(t): the S-curve runs from 0 to 1
        if order == 0:
            return np.clip(self.h(x), 0.0, 1.0)
        h1 = self.h(x, 1)
        d = [self.total * self.curve(t, n) for n in (1, 2, 3)]
        if order == 1:
            return h1 * d[0]
        h2 = self.h(x, 2)
        if order == 2:
            return h2 * d[0] ** 2 + h1 * d[1]
        return self.h(x, 3) * d[0] ** 3 + 3.0 * h2 * d[0] * d[1] + h1 * d[2]

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] at which s is reached: sigma(s) / total through the S-curve's inverse."""
        grid = np.linspace(0.0, self.total, SHAPE_GRID)
        sig = np.interp(np.asarray(s, dtype=float), self.h(grid), grid)
        return self.curve.time_at(sig / self.total)


def _speed_shape(
    s: np.ndarray, cap: np.ndarray, acc_int: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The speed shape g on a uniform grid u: the caps' forward/backward pass (as
    ``GridTiming``, without rest at the ends) under ``SHAPE_SHARE`` of the path acceleration,
    then a running minimum and two running means (never above the pass, C1 and smooth)."""
    v2 = np.minimum(cap, 1e9) ** 2
    A = np.concatenate([[0.0], np.cumsum(2.0 * SHAPE_SHARE * acc_int * np.diff(s))])
    v2 = np.minimum(v2, np.minimum.accumulate(v2 - A) + A)
    v2 = np.minimum(v2, np.minimum.accumulate((v2 + A)[::-1])[::-1] - A)
    u = np.linspace(0.0, 1.0, SHAPE_GRID)
    # The smallest cap in each grid cell, so the grid misses no dip between its points.
    cell = np.clip(np.searchsorted(u, s, side="right") - 1, 0, SHAPE_GRID - 2)
    low = np.full(SHAPE_GRID - 1, np.inf)
    np.minimum.at(low, cell, np.sqrt(np.maximum(v2, 0.0)))
    gu = np.interp(u, s, np.sqrt(np.maximum(v2, 0.0)))
    gu = np.minimum(gu, np.concatenate([low, [np.inf]]))
    gu = np.minimum(gu, np.concatenate([[np.inf], low]))
    w = max(3, int(SHAPE_SMOOTHING * SHAPE_GRID) | 1)
    pad = w // 2
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(gu, pad, mode="edge"), w)
    g = windows.min(axis=1)
    for _ in range(2):
        g = np.convolve(np.pad(g, pad, mode="edge"), np.ones(w) / w, mode="valid")
    return u, np.maximum(g, 1e-9)


def _s_curve(
    c: ChunkInput,
    s: np.ndarray,
    path: CubicSpline,
    cap: np.ndarray,
    acc_int: np.ndarray,
    dp: np.ndarray,
    dw: np.ndarray,
) -> ChunkTiming:
    """An S-curve chunk, the shorter of two laws after a dense check: one ``SCurveTiming`` under
    the chunk's smallest speed cap and path acceleration (conservative, as ``s_curve_limited``),
    and a ``ShapedSCurve`` whose speed follows the caps along the path. Both bound s''' by the
    tool jerk limits over the largest tool rate per unit s (``c.jerk``). The dense check of the
    joint velocities and accelerations and of the tool's linear jerk P3 s'^3 + 3 P2 s' s'' +
    P1 s''' (P: a C2 spline of the tool positions) stretches each law's time uniformly where
    needed (velocity by 1/k, acceleration by 1/k^2, jerk by 1/k^3)."""
    j_lin, j_ang = c.jerk  # type: ignore[misc]
    bounds = [np.inf]
    if dp.max() > _TINY:
        bounds.append(j_lin / dp.max())
    if dw.max() > _TINY:
        bounds.append(j_ang / dw.max())
    j_max = min(bounds)
    if not np.isfinite(j_max):  # the tool does not move (a pure wrist turn is caught above)
        j_max = 1e6
    laws: list[SCurveTiming | ShapedSCurve] = [
        SCurveTiming(
            max_velocity=float(min(np.min(cap), 1e9)),
            max_acceleration=float(np.min(acc_int)),
            max_jerk=float(j_max),
        )
    ]
    # The tool's jerk along a curve at speed s' grows as |P3| s'^3 (v^3 / r^2 on a circle of
    # radius r): a speed cap for the shape, with a quarter of the jerk limit for that term.
    tool = CubicSpline(s, c.T[:, :3, 3])
    p3 = _norm_rows(6.0 * tool.c[0])
    p3 = np.maximum(np.concatenate([p3[:1], p3]), np.concatenate([p3, p3[-1:]]))
    with np.errstate(divide="ignore"):
        cap_jerk = np.where(p3 > _TINY, np.cbrt(0.25 * j_lin / p3), np.inf)
    shape_cap = np.minimum(cap, cap_jerk)
    end_acc = float(min(acc_int[0], acc_int[-1]))
    best = _checked(c, s, path, tool, laws[0], j_lin)[0]
    for _ in range(SHAPE_ROUNDS):
        # Where the dense check finds the shaped law over a limit, its cap drops by that factor
        # (velocity 1/k, acceleration 1/k^2, jerk 1/k^3) over a neighbourhood; then again.
        u, g = _speed_shape(s, shape_cap, acc_int)
        law = ShapedSCurve(u, g, (1 - SHAPE_SHARE) * end_acc, j_max)
        if not law.monotone:
            break
        timing, s_d, over = _checked(c, s, path, tool, law, j_lin)
        if timing.duration < best.duration:
            best = timing
        if timing.stretch == 1.0:
            break
        factor = np.ones(len(s))
        i = np.clip(np.searchsorted(s, s_d), 0, len(s) - 1)
        np.maximum.at(factor, i, over)
        reach = max(1, int(SHAPE_SMOOTHING * len(s)))
        window = np.lib.stride_tricks.sliding_window_view(
            np.pad(factor, reach, mode="edge"), 2 * reach + 1
        )
        shape_cap = shape_cap / window.max(axis=1)
    return best


def _checked(
    c: ChunkInput,
    s: np.ndarray,
    path: CubicSpline,
    tool: CubicSpline,
    law: SCurveTiming | ShapedSCurve,
    j_lin: float,
) -> tuple[ChunkTiming, np.ndarray, np.ndarray]:
    """``law`` with its uniform stretch after the dense check (see ``_s_curve``), the path
    parameters of the dense check and the factor (>= 1) by which each is over a limit."""
    end = law.duration
    frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
    knots = np.unique(np.concatenate([law.time_at(s), np.linspace(0.0, end, 201)]))
    dense = np.concatenate([(knots[:-1, None] + np.diff(knots)[:, None] * frac).ravel(), [end]])
    _, vel, accel = _evaluate(law, path, dense, end)
    s_d = np.clip(law(dense), 0.0, 1.0)
    i = np.clip(np.searchsorted(s, s_d, side="right") - 1, 0, len(s) - 2)
    v_lim, a_lim = np.minimum(c.v_max[i], c.v_max[i + 1]), np.minimum(c.a_max[i], c.a_max[i + 1])
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
    timing = ChunkTiming(
        knot_times=t * stretch,
        duration=float(end * stretch),
        stretch=stretch,
        law=law,
        path=path,
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        over = np.maximum.reduce(
            [
                np.max(np.abs(vel) / v_lim, axis=1),
                np.sqrt(np.max(np.abs(accel) / a_lim, axis=1)),
                np.cbrt(jerk / j_lin) if np.isfinite(j_lin) else np.zeros(len(jerk)),
            ]
        )
    return timing, s_d, np.maximum(over, 1.0)
