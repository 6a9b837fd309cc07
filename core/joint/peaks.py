"""Exact extrema of polynomials: the peaks every profile reports come from here, not from samples.

``polyval`` and ``polyder`` work on coefficient arrays ``(m, ...)`` (highest power first, vectorized
over trailing axes); ``unit_roots`` finds the real roots in ``[0, 1]`` of degree <= 3;
``abs_peak_on_unit`` gives ``max |p|`` over ``[0, 1]`` for degree <= 4; ``piecewise_peaks`` gives
the exact peaks of a piecewise polynomial in time (a spline, a Ruckig profile, or a Cartesian plan
whose pieces are known), for every planner.
"""

from __future__ import annotations

import numpy as np

from core.trajectory import Peaks


def polyval(coeffs: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Horner evaluation; ``coeffs`` ``(m, ...)`` highest power first, ``s`` broadcast to it."""
    out = np.zeros(np.broadcast_shapes(coeffs.shape[1:], np.shape(s)))
    for c in coeffs:
        out = out * s + c
    return out


def polyder(coeffs: np.ndarray, order: int = 1) -> np.ndarray:
    """Coefficients ``(m - order, ...)`` of the ``order``-th derivative (at least one row)."""
    for _ in range(order):
        m = coeffs.shape[0]
        if m == 1:
            return np.zeros_like(coeffs)
        powers = np.arange(m - 1, 0, -1, dtype=float).reshape((-1,) + (1,) * (coeffs.ndim - 1))
        coeffs = coeffs[:-1] * powers
    return coeffs


def _quadratic_roots(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Real roots of ``a x^2 + b x + c`` (linear when ``a == 0``), ``(2, ...)``, NaN where none."""
    with np.errstate(all="ignore"):
        disc = b * b - 4.0 * a * c
        q = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
        roots = np.stack([q / a, c / q])
    return np.where(np.isfinite(roots) & (disc >= 0.0), roots, np.nan)


def unit_roots(coeffs: np.ndarray, iterations: int = 60) -> np.ndarray:
    """Real roots in ``[0, 1]`` of polynomials of degree <= 3, vectorized over trailing axes.

    Degree <= 2 in closed form. A cubic's critical points (closed form) split ``[0, 1]`` into at
    most three monotone pieces; a root in a piece with a sign change is found by Newton steps kept
    inside the bracket, with bisection when a step leaves it or fails to halve the previous one
    ("rtsafe"). Returns ``(3, ...)``, NaN-padded.
    """
    c = np.concatenate([np.zeros((4 - coeffs.shape[0], *coeffs.shape[1:])), coeffs])
    if not np.any(c[0]):
        roots = _quadratic_roots(c[1], c[2], c[3])
        roots = np.where((roots >= 0.0) & (roots <= 1.0), roots, np.nan)
        return np.concatenate([roots, np.full((1, *roots.shape[1:]), np.nan)])
    cuts = np.nan_to_num(np.clip(_quadratic_roots(3.0 * c[0], 2.0 * c[1], c[2]), 0.0, 1.0))
    zeros, ones = np.zeros_like(c[0]), np.ones_like(c[0])
    edges = np.sort(np.concatenate([zeros[None], cuts, ones[None]]), axis=0)
    lo, hi = edges[:-1], edges[1:]
    cc, dc = c[:, None], polyder(c)[:, None]
    p_lo, p_hi = polyval(cc, lo), polyval(cc, hi)
    bracketed = p_lo * p_hi <= 0.0
    # |p| below the round-off of evaluating p on [0, 1] is a root. A bracket's end that is one (a
    # rest-to-rest profile's, at s = 0 and s = 1) is taken as is: Newton steps from inside overshoot
    # it, and bisection would take ~45 halvings to reach the step tolerance.
    noise = 8.0 * np.finfo(float).eps * np.abs(c).sum(axis=0)
    x = np.where(np.abs(p_lo) <= noise, lo, np.where(np.abs(p_hi) <= noise, hi, 0.5 * (lo + hi)))
    moved = hi - lo
    for _ in range(iterations):
        px = polyval(cc, x)
        right = np.sign(px) == np.sign(p_lo)
        lo, p_lo, hi = np.where(right, x, lo), np.where(right, px, p_lo), np.where(right, hi, x)
        with np.errstate(all="ignore"):
            newton = x - px / polyval(dc, x)
        step = np.abs(newton - x)
        converged = (np.abs(px) <= noise) | (step <= 1e-14)  # s in [0, 1]: absolute tolerances
        fast = (newton >= lo) & (newton <= hi) & (2.0 * step <= moved)
        nxt = np.where(fast, newton, 0.5 * (lo + hi))
        nxt = np.where(converged, np.clip(np.where(np.abs(px) <= noise, x, newton), lo, hi), nxt)
        moved, x = np.abs(nxt - x), nxt
        if np.all(converged | ~bracketed):
            break
    return np.where(bracketed, x, np.nan)


def abs_peak_on_unit(coeffs: np.ndarray) -> np.ndarray:
    """``max |p(s)|`` over ``s`` in ``[0, 1]`` for degree <= 4, exact up to round-off; ``(...)``."""
    crit = unit_roots(polyder(coeffs))
    ends = np.stack([np.zeros(coeffs.shape[1:]), np.ones(coeffs.shape[1:])])
    cand = np.concatenate([ends, np.nan_to_num(crit, nan=0.0)])
    return np.abs(polyval(coeffs[:, None], cand)).max(axis=0)


def piecewise_peaks(coeffs: np.ndarray, widths: np.ndarray) -> Peaks:
    """Exact peaks of a piecewise polynomial in time of degree <= 5, over every piece.

    Args:
        coeffs: ``(m, pieces, dof)`` coefficients in the local time ``tau`` [s] of each piece,
            highest power first (``m <= 6``), as scipy's ``PPoly.c``.
        widths: ``(pieces,)`` piece durations [s], > 0.

    Returns:
        ``Peaks`` of |q'|, |q''|, |q'''| per joint, each ``(dof,)``; zeros where the degree is lower.
    """
    coeffs = np.asarray(coeffs, dtype=float)
    if coeffs.shape[0] > 6:
        raise ValueError("piecewise_peaks takes degree <= 5")
    h = np.asarray(widths, dtype=float)[:, None]
    m = coeffs.shape[0]
    # Each piece on s = tau / h in [0, 1]: the coefficient of s^k is c_k h^k.
    powers = np.arange(m - 1, -1, -1, dtype=float).reshape(-1, 1, 1)
    unit = coeffs * h[None] ** powers
    out = []
    for order in (1, 2, 3):
        if m <= order:
            out.append(np.zeros(coeffs.shape[2]))
            continue
        out.append((abs_peak_on_unit(polyder(unit, order)) / h**order).max(axis=0))
    return Peaks(*out)
