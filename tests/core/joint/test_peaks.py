"""Exact polynomial extrema: roots in [0, 1] against numpy, known peaks, and piecewise peaks of a
scipy spline against a dense resampling."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline, PPoly

from core.joint.peaks import abs_peak_on_unit, piecewise_peaks, polyval, unit_roots

RNG_SEED = 20240402


def test_unit_roots_agree_with_numpy() -> None:
    rng = np.random.default_rng(RNG_SEED + 6)
    coeffs = rng.normal(size=(4, 2000)) * rng.choice([1e-6, 1.0, 1e6], size=(4, 2000))
    coeffs[0, :300] = 0.0  # some quadratics
    roots = unit_roots(coeffs)
    for k in range(coeffs.shape[1]):
        c = coeffs[:, k]
        expected = [
            r.real for r in np.roots(c) if abs(r.imag) < 1e-12 and 1e-9 <= r.real <= 1 - 1e-9
        ]
        got = roots[:, k][~np.isnan(roots[:, k])]
        for r in expected:
            nearest = got[np.argmin(np.abs(got - r))]
            residual = abs(polyval(c[:, None], np.array([nearest]))[0])
            assert residual <= 1e-12 * (np.abs(c).sum()), (c, r, got)


def test_abs_peak_on_unit_of_a_known_quartic() -> None:
    # 30 s^2 (1 - s)^2 (the quintic's normalized velocity) peaks at 1.875 at s = 1/2.
    c = np.array([30.0, -60.0, 30.0, 0.0, 0.0])[:, None]
    assert abs(abs_peak_on_unit(c)[0] - 1.875) < 1e-14


def test_unit_roots_take_roots_at_the_bracket_ends_at_once() -> None:
    """The rest-to-rest quintic's jerk has roots at s = 0 and 1 (and 1/2): found exactly, without
    ~45 bisection steps toward an end (the loop ends after its first iteration)."""
    c = np.array([120.0, -180.0, 60.0, 0.0])[:, None] * np.array([1.0, -2.5, 1e-3])
    roots = unit_roots(c)
    np.testing.assert_allclose(
        np.sort(roots, axis=0), [[0.0] * 3, [0.5] * 3, [1.0] * 3], atol=1e-15
    )


def test_piecewise_peaks_of_splines_and_quintic_pieces() -> None:
    rng = np.random.default_rng(RNG_SEED + 60)
    for degree in (3, 5):
        breaks = np.concatenate([[0.0], np.cumsum(rng.uniform(0.1, 2.0, 12))])
        if degree == 3:
            pp = CubicSpline(breaks, rng.normal(size=(13, 4)), axis=0)
        else:
            pp = PPoly(rng.normal(size=(6, 12, 4)), breaks)
        widths = np.diff(breaks)
        peaks = piecewise_peaks(pp.c, widths)
        for order, got in enumerate(peaks, start=1):
            # Each piece densely on its own closed interval (both ends: a piecewise polynomial
            # need not be continuous), by numpy's polyder/polyval.
            dense = np.zeros(4)
            for i, h in enumerate(widths):
                tau = np.linspace(0.0, h, 20_001)
                for j in range(4):
                    d = np.polyder(pp.c[:, i, j], order)
                    dense[j] = max(dense[j], np.abs(np.polyval(d, tau)).max())
            assert np.all(got >= dense * (1 - 1e-12)), (degree, order)
            np.testing.assert_allclose(got, dense, rtol=1e-6)


def test_piecewise_peaks_of_lower_degrees_are_zero() -> None:
    linear = np.array([[[2.0]], [[1.0]]])  # q = 2 tau + 1 on one piece
    peaks = piecewise_peaks(linear, np.array([3.0]))
    assert peaks.velocity[0] == 2.0 and peaks.acceleration[0] == 0.0 and peaks.jerk[0] == 0.0
