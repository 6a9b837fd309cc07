"""Shortening and smoothing (``core.motion.shorten``, ``core.motion.smooth``): never longer, ends
kept, still clear everywhere (dense sweep of the closed-form distances), deterministic per seed."""

from __future__ import annotations

import numpy as np

from core.motion.certify import CERTIFY_MARGIN, Certifier
from core.motion.shorten import path_length, shorten
from core.motion.smooth import resample, smooth
from tests.core.motion.discs import Discs, min_margin_dense

DISCS = Discs([[0.0, 0.0], [0.0, 1.6]], [0.8, 0.5], clearance=0.05)
ZIGZAG = np.array(
    [[-2.0, 0.1], [-1.5, -1.2], [-0.5, -0.9], [-0.2, -1.8], [0.6, -1.0], [1.2, -1.6], [2.0, -0.1]]
)
LOWER, UPPER = np.full(2, -3.0), np.full(2, 3.0)


def test_zigzag_is_a_certified_start() -> None:
    assert Certifier(DISCS).path(ZIGZAG).ok


def test_shorten_keeps_the_ends_and_the_clearance() -> None:
    c = Certifier(DISCS)
    a = shorten(c, ZIGZAG, np.random.default_rng(7))
    b = shorten(Certifier(DISCS), ZIGZAG, np.random.default_rng(7))
    np.testing.assert_array_equal(a.knots, b.knots)
    np.testing.assert_array_equal(a.knots[[0, -1]], ZIGZAG[[0, -1]])
    assert path_length(a.knots) < path_length(ZIGZAG)
    assert min_margin_dense(DISCS, a.knots) >= CERTIFY_MARGIN - 1e-12


def test_smooth_shortens_and_keeps_the_clearance() -> None:
    c = Certifier(DISCS)
    out = smooth(c, ZIGZAG, LOWER, UPPER)
    assert out.accepted >= 1
    assert path_length(out.knots) < path_length(ZIGZAG)
    np.testing.assert_array_equal(out.knots[[0, -1]], ZIGZAG[[0, -1]])
    assert min_margin_dense(DISCS, out.knots) >= CERTIFY_MARGIN - 1e-12
    assert np.all(out.knots >= LOWER) and np.all(out.knots <= UPPER)


def test_resample_keeps_the_knots_and_the_path() -> None:
    dense = resample(ZIGZAG, spacing=0.2, most=200)
    for q in ZIGZAG:
        assert np.min(np.linalg.norm(dense - q, axis=1)) < 1e-12
    assert np.linalg.norm(np.diff(dense, axis=0), axis=1).max() <= 0.2 + 1e-12
    assert path_length(dense) == np.float64(path_length(dense))
    np.testing.assert_allclose(path_length(dense), path_length(ZIGZAG))
