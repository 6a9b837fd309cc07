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
_GOLD = 0.3819660112501051


def sampled_peaks(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Peak estimate and its fraction in [0, 1] of each interval and row, each ``(N, m)``, from
    ``values`` ``(N, K, m)`` sampled at fractions ``k / (K - 1)``."""
    n, k, m = values.shape
    top = values.argmax(axis=1)
    centre = np.clip(top, 1, k - 2)
    i, r = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    v0, v1, v2 = values[i, centre - 1, r], values[i, centre, r], values[i, centre + 1, r]
    curve = v0 - 2.0 * v1 + v2
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(curve < 0, 0.5 * (v0 - v2) / curve, np.nan)
        vertex = v1 - 0.25 * (v0 - v2) * offset
    inside = np.isfinite(offset) & (np.abs(offset) <= 1.0)
    best = values[i, top, r]
    where = top / (k - 1)
    better = inside & (vertex > best)
    peak = np.where(better, vertex, best)
    return peak, np.where(better, (centre + np.nan_to_num(offset)) / (k - 1), where)


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
    h = 1.0 / (samples - 1)
    lo = np.clip(fraction - h, 0.0, 1.0)
    hi = np.clip(fraction + h, 0.0, 1.0)
    mid = np.clip(fraction, lo + 1e-9 * h, hi - 1e-9 * h)
    f_lo, f_mid, f_hi = (evaluate(interval, f, row) for f in (lo, mid, hi))
    best = np.maximum(np.maximum(f_lo, f_mid), f_hi)
    for _ in range(REFINE_STEPS):
        # keep the middle point the highest: a bracket of a local maximum (or an end of it)
        a, b, c = mid - lo, mid - hi, f_mid
        num = a * a * (c - f_hi) - b * b * (c - f_lo)
        den = a * (c - f_hi) - b * (c - f_lo)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = mid - 0.5 * num / den
        wide = np.where(hi - mid > mid - lo, hi, lo)
        golden = mid + _GOLD * (wide - mid)
        ok = np.isfinite(x) & (x > lo) & (x < hi) & (np.abs(x - mid) > 1e-12)
        x = np.where(ok, x, golden)
        fx = evaluate(interval, x, row)
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
    return best
