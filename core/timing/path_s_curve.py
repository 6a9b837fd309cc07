"""The ``s_curve`` law on a joint path: continuous s'', bounded path jerk, within the limits.

A motion program's chunk holding a LIN/CIRC with ``speed_profile="s_curve"`` is timed by the
shorter of two laws, each after a dense check: one ``SCurveTiming`` (Ruckig, one degree of
freedom) under the chunk's smallest speed cap and path acceleration (conservative, as
``s_curve_limited``), and a ``ShapedSCurve`` whose speed follows the caps of
``core.timing.path_limits`` along the path (slower in sharp blends only). Both bound the path
jerk by the tool jerk limits over the largest tool rate per unit s (``PathLimits.tool_jerk``).
The dense check of the joint velocities and accelerations and of the tool's linear jerk
(P3 s'^3 + 3 P2 s' s'' + P1 s'''; P a C2 spline of the tool positions) stretches each law's time
uniformly where needed (velocity by 1/k, acceleration by 1/k^2, jerk by 1/k^3). The path runs
over s in [0, 1] (``path.length`` 1).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from core.timing.joint_path import JointPath
from core.timing.path_limits import TINY, PathLimits, path_caps
from core.timing.path_profile import Stretched, dense_times, joint_motion, stretch_for
from core.timing.s_curve import SCurveTiming

CHECKS_PER_INTERVAL = 10
"""Dense checks of the limits per interval of the law's knots."""

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

    def switch_times(self) -> np.ndarray:
        """Times [s] where the path jerk steps (the S-curve's phase boundaries)."""
        return self.curve.switch_times()


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


def shaped_s_curve(path: JointPath, limits: PathLimits) -> Stretched:
    """The S-curve law of ``path`` under ``limits`` (see the module docstring)."""
    if abs(float(path.length) - 1.0) > 1e-12:
        raise ValueError("the s_curve path law times paths over s in [0, 1]")
    s = limits.s
    caps = path_caps(path, limits)
    cap, acc_int = caps.cap, caps.acceleration
    j_lin, j_ang = limits.tool_jerk if limits.tool_jerk is not None else (np.inf, np.inf)
    dp, dw = limits.tool_rate[:, 0], limits.tool_rate[:, 1]
    bounds = [np.inf]
    if dp.max() > TINY:
        bounds.append(j_lin / dp.max())
    if dw.max() > TINY:
        bounds.append(j_ang / dw.max())
    j_max = min(bounds)
    if not np.isfinite(j_max):  # the tool does not move (a pure wrist turn is caught above)
        j_max = 1e6
    first = SCurveTiming(
        max_velocity=float(min(np.min(cap), 1e9)),
        max_acceleration=float(np.min(acc_int)),
        max_jerk=float(j_max),
    )
    # The tool's jerk along a curve at speed s' grows as |P3| s'^3 (v^3 / r^2 on a circle of
    # radius r): a speed cap for the shape, with a quarter of the jerk limit for that term.
    positions = limits.tool_positions
    tool = CubicSpline(s, np.zeros((len(s), 3)) if positions is None else positions)
    p3 = norm_rows(6.0 * tool.c[0])
    p3 = np.maximum(np.concatenate([p3[:1], p3]), np.concatenate([p3, p3[-1:]]))
    with np.errstate(divide="ignore"):
        cap_jerk = np.where(p3 > TINY, np.cbrt(0.25 * j_lin / p3), np.inf)
    shape_cap = np.minimum(cap, cap_jerk)
    end_acc = float(min(acc_int[0], acc_int[-1]))
    best = _checked(path, limits, tool, first, j_lin)[0]
    for _ in range(SHAPE_ROUNDS):
        # Where the dense check finds the shaped law over a limit, its cap drops by that factor
        # (velocity 1/k, acceleration 1/k^2, jerk 1/k^3) over a neighbourhood; then again.
        u, g = _speed_shape(s, shape_cap, acc_int)
        law = ShapedSCurve(u, g, (1 - SHAPE_SHARE) * end_acc, j_max)
        if not law.monotone:
            break
        timed, s_d, over = _checked(path, limits, tool, law, j_lin)
        if timed.duration < best.duration:
            best = timed
        if timed.stretch == 1.0:
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
    path: JointPath,
    limits: PathLimits,
    tool: CubicSpline,
    law: SCurveTiming | ShapedSCurve,
    j_lin: float,
) -> tuple[Stretched, np.ndarray, np.ndarray]:
    """``law`` with its uniform stretch after the dense check (see the module docstring), the path
    parameters of the dense check and the factor (>= 1) by which each is over a limit."""
    s = limits.s
    end = law.duration
    knots = np.unique(np.concatenate([law.time_at(s), np.linspace(0.0, end, 201)]))
    dense = dense_times(knots, CHECKS_PER_INTERVAL)
    _, vel, accel = joint_motion(path, law, dense)
    s_d = np.clip(law(dense), 0.0, 1.0)
    i = np.clip(np.searchsorted(s, s_d, side="right") - 1, 0, len(s) - 2)
    v_lim = np.minimum(limits.velocity[i], limits.velocity[i + 1])
    a_lim = np.minimum(limits.acceleration[i], limits.acceleration[i + 1])
    sd, sdd, sddd = law(dense, 1), law(dense, 2), law(dense, 3)
    jerk = np.zeros(len(dense))
    for back in (0, 1):  # P3 steps at the knots: both neighbouring pieces
        piece = np.clip(np.searchsorted(s, s_d, side="right") - 1 - back, 0, len(s) - 2)
        vec = (
            6.0 * tool.c[0, piece] * (sd**3)[:, None]
            + 3.0 * tool(s_d, 2) * (sd * sdd)[:, None]
            + tool(s_d, 1) * sddd[:, None]
        )
        jerk = np.maximum(jerk, norm_rows(vec))
    ratio_v = float(np.max(np.abs(vel) / v_lim))
    ratio_a = float(np.max(np.abs(accel) / a_lim))
    ratio_j = float(jerk.max() / j_lin) if np.isfinite(j_lin) else 0.0
    timed = Stretched(law, stretch_for((ratio_v, ratio_a, ratio_j)))
    with np.errstate(divide="ignore", invalid="ignore"):
        over = np.maximum.reduce(
            [
                np.max(np.abs(vel) / v_lim, axis=1),
                np.sqrt(np.max(np.abs(accel) / a_lim, axis=1)),
                np.cbrt(jerk / j_lin) if np.isfinite(j_lin) else np.zeros(len(jerk)),
            ]
        )
    return timed, s_d, np.maximum(over, 1.0)


def norm_rows(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=1)
