"""The largest value of a limit's ratio inside each grid interval, between its samples.

A path timing law keeps its limits at a few points of every grid interval; in between they may be
exceeded. ``sampled_peaks`` estimates each interval's peak from samples at evenly spaced fractions
of the interval: the largest sample, or the vertex of the parabola through the largest and its two
neighbours when that is higher (exact for a quadratic, such as a cubic spline's joint acceleration
under a constant s''). ``refine_peaks`` then finds chosen peaks to ~1e-13 by successive parabolic
interpolation inside the bracket of samples around them (vectorized over the candidates; golden
section when a parabola's vertex leaves the bracket), evaluating the true limit anywhere.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

REFINE_STEPS = 8
"""Parabolic (or golden-section) steps of ``refine_peaks``."""
MIN_STEP = 1e-9
"""Parabolic steps closer than this share of the bracket to its middle point are golden ones."""
QUADRATIC = 1e-12
"""Samples that a parabola through three of them predicts at a fourth to this (relative) are
taken as samples of a parabola: its vertex is the peak, nothing to refine."""
_GOLD = 0.3819660112501051


def sampled_peaks(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Peak estimate and its fraction in [0, 1] of each interval and row, each ``(N, m)``, from
    ``values`` ``(N, K, m)`` sampled at fractions ``k / (K - 1)``."""
    k = values.shape[1]
    top = values.argmax(axis=1)
    centre = np.clip(top, 1, k - 2)[:, None]
    v0, v1, v2 = (np.take_along_axis(values, centre + o, axis=1)[:, 0] for o in (-1, 0, 1))
    best = np.take_along_axis(values, top[:, None], axis=1)[:, 0]
    return parabola_peak(v0, v1, v2, best, top, k)


def parabola_peak(
    v0: np.ndarray, v1: np.ndarray, v2: np.ndarray, best: np.ndarray, top: np.ndarray, k: int
) -> tuple[np.ndarray, np.ndarray]:
    """Peak estimate and its fraction from the largest of ``k`` samples (``best``, at index
    ``top``) and the three samples ``v0, v1, v2`` around it (centred at ``clip(top, 1, k - 2)``):
    the vertex of their parabola where it is higher (arrays of any one shape)."""
    centre = np.clip(top, 1, k - 2)
    curve = v0 - 2.0 * v1 + v2
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(curve < 0, 0.5 * (v0 - v2) / curve, np.nan)
        vertex = v1 - 0.25 * (v0 - v2) * offset
    better = np.isfinite(offset) & (np.abs(offset) <= 1.0) & (vertex > best)
    where = np.where(better, (centre + np.nan_to_num(offset)) / (k - 1), top / (k - 1))
    return np.where(better, vertex, best), where


def is_parabola(samples: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Whether the parabola through ``samples`` ``(C, K)`` (evenly spaced, K >= 4) at
    ``centre - 1, centre, centre + 1`` ``(C,)`` also passes through a fourth of them (to
    ``QUADRATIC``): then its vertex is exact (a cubic spline's joint acceleration under a
    constant s'')."""
    k = samples.shape[1]
    pick = np.arange(len(centre))
    far = np.where(centre + 2 <= k - 1, centre + 2, centre - 2)
    v0, v1, v2 = samples[pick, centre - 1], samples[pick, centre], samples[pick, centre + 1]
    t = (far - centre).astype(float)  # +-2: the parabola's value there
    predicted = v1 + 0.5 * t * (v2 - v0) + 0.5 * t * t * (v0 - 2.0 * v1 + v2)
    actual = samples[pick, far]
    scale = np.abs(v0) + np.abs(v1) + np.abs(v2) + np.abs(actual)
    return np.abs(actual - predicted) <= QUADRATIC * scale


def refine_peaks(
    evaluate: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    interval: np.ndarray,
    row: np.ndarray,
    fraction: np.ndarray,
    samples: int,
) -> np.ndarray:
    """The peak of row ``row`` in interval ``interval`` near ``fraction`` (each ``(C,)``), where
    the interval was sampled at ``samples`` evenly spaced fractions: ``evaluate(interval, f, row)``
    gives the row's value at fractions ``f`` ``(C,)``. Returns ``(C,)``, at least every value
    it evaluated."""
    return refine_peaks_at(evaluate, interval, row, fraction, samples)[0]


def refine_peaks_at(
    evaluate: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    interval: np.ndarray,
    row: np.ndarray,
    fraction: np.ndarray,
    samples: int,
) -> tuple[np.ndarray, np.ndarray]:
    """``refine_peaks`` and the fraction where each peak is."""
    h = 1.0 / (samples - 1)
    lo = np.clip(fraction - h, 0.0, 1.0)
    hi = np.clip(fraction + h, 0.0, 1.0)
    mid = np.clip(fraction, lo + 1e-9 * h, hi - 1e-9 * h)
    f_lo, f_mid, f_hi = (evaluate(interval, f, row) for f in (lo, mid, hi))
    best = np.maximum(np.maximum(f_lo, f_mid), f_hi)
    arg = np.where(best == f_mid, mid, np.where(best == f_lo, lo, hi))
    for _ in range(REFINE_STEPS):
        # keep the middle point the highest: a bracket of a local maximum (or an end of it)
        a, b, c = mid - lo, mid - hi, f_mid
        num = a * a * (c - f_hi) - b * b * (c - f_lo)
        den = a * (c - f_hi) - b * (c - f_lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = mid - 0.5 * num / den
        wide = np.where(hi - mid > mid - lo, hi, lo)
        golden = mid + _GOLD * (wide - mid)
        # a step too close to the middle point tells nothing (an equal value would move the
        # bracket off the peak): a golden step instead
        ok = np.isfinite(x) & (x > lo) & (x < hi) & (np.abs(x - mid) > MIN_STEP * (hi - lo))
        x = np.where(ok, x, golden)
        fx = evaluate(interval, x, row)
        arg = np.where(fx > best, x, arg)
        best = np.maximum(best, fx)
        right = x > mid
        up = fx >= f_mid
        # the new point replaces an end, or becomes the middle
        lo, f_lo = (
            np.where(up & right | ~up & ~right, np.where(up, mid, x), lo),
            np.where(up & right | ~up & ~right, np.where(up, f_mid, fx), f_lo),
        )
        hi, f_hi = (
            np.where(up & ~right | ~up & right, np.where(up, mid, x), hi),
            np.where(up & ~right | ~up & right, np.where(up, f_mid, fx), f_hi),
        )
        mid, f_mid = np.where(up, x, mid), np.where(up, fx, f_mid)
        if np.all(hi - lo < 1e-12):
            break
    return best, arg
