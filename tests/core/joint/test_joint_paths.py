"""The geometric joint paths of retime: the chord-length spline and the blended (TOTG) path.

References: scipy's CubicSpline (the spline is it, in the chord-length parameter), finite differences
of q(s) (the exact derivatives), the corner geometry (deviation, tangency, half segments).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar

from core.joint.blended_path import BlendedPath
from core.joint.spline_path import SplinePath
from core.timing.joint_path import JointPath


def walk(seed: int, n: int = 8, dof: int = 4) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.uniform(-0.5, 0.5, (n, dof)), axis=0)


def fd_errors(path: JointPath, h: float = 1e-6) -> list[float]:
    """Largest |finite difference - exact| of orders 1-3 away from breakpoints."""
    s = np.linspace(0.0, path.length, 3001)[1:-1]
    b = path.breakpoints()
    s = s[np.min(np.abs(s[:, None] - b[None]), axis=1) > 10 * h]
    out = []
    for order in (1, 2, 3):
        fd = (path(s + h, order - 1) - path(s - h, order - 1)) / (2 * h)
        out.append(
            float(np.abs(fd - path(s, order)).max() / max(1.0, np.abs(path(s, order)).max()))
        )
    return out


@pytest.mark.parametrize("seed", range(4))
def test_spline_is_scipys_cubic_in_chord_length(seed: int) -> None:
    q = walk(seed)
    path = SplinePath(q)
    chords = np.linalg.norm(np.diff(q, axis=0), axis=1)
    assert path.length == pytest.approx(chords.sum(), rel=1e-15)
    np.testing.assert_allclose(path(path.knots), q, atol=1e-12)
    reference = CubicSpline(np.concatenate([[0], np.cumsum(chords)]), q, bc_type="not-a-knot")
    s = np.linspace(0, path.length, 777)
    for order in (0, 1, 2):
        np.testing.assert_allclose(path(s, order), reference(s, order), atol=1e-12)
    assert max(fd_errors(path)) < 1e-5
    # C2 at the knots: d2q/ds2 from both sides agrees
    k = path.knots[1:-1]
    np.testing.assert_allclose(path(k - 1e-9, 2), path(k + 1e-9, 2), atol=1e-6)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("deviation", [0.01, 0.1, 1.0])
def test_blended_corners(seed: int, deviation: float) -> None:
    q = walk(seed)
    path = BlendedPath(q, deviation)
    s = np.linspace(0, path.length, 200_001)
    points = path(s)
    for k in range(1, len(q) - 1):
        # the path passes within max_deviation of every corner (closest point found exactly)
        i = int(np.linalg.norm(points - q[k], axis=1).argmin())
        lo, hi = s[max(i - 1, 0)], s[min(i + 1, len(s) - 1)]
        closest = minimize_scalar(
            lambda x, k=k: float(np.linalg.norm(path(np.array([x]))[0] - q[k])),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-12},
        )
        assert closest.fun <= deviation + 1e-9
    # arc length parameter: |dq/ds| = 1; q and dq/ds continuous at every junction
    np.testing.assert_allclose(np.linalg.norm(path(s, 1), axis=1), 1.0, atol=1e-12)
    b = path.breakpoints()[1:-1]
    for order in (0, 1):
        jump = np.abs(path(b - 1e-9, order) - path(b + 1e-9, order)).max()
        assert jump < 1e-6
    assert max(fd_errors(path)) < 1e-4
    # ends are the first and last waypoints; the path stays in the waypoints' bounding box
    np.testing.assert_allclose(path(np.array([0.0, path.length])), q[[0, -1]], atol=1e-12)
    assert np.all(points >= q.min(axis=0) - 1e-9) and np.all(points <= q.max(axis=0) + 1e-9)


def test_blended_uses_at_most_half_of_each_segment() -> None:
    q = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.2], [3.0, 0.2]])
    path = BlendedPath(q, 10.0)  # a huge deviation: the half segments limit the arcs
    b = path.breakpoints()
    # each arc reaches half the shorter neighbour (0.1 m) along both segments: the first starts
    # at x = 0.9, and the two arcs meet in the middle of the short segment, with no line between
    assert b[1] == pytest.approx(0.9, abs=1e-12)
    assert len(b) == 5
    np.testing.assert_allclose(path(np.array([b[2]]))[0], [1.0, 0.1], atol=1e-12)


def test_collinear_and_reversing_corners() -> None:
    straight = BlendedPath(np.array([[0.0], [1.0], [3.0]]), 0.1)
    assert straight.arcs == 0 and straight.length == pytest.approx(3.0)
    back = BlendedPath(np.array([[0.0, 0.0], [1.0, 1.0], [0.0, 0.0]]), 0.1)
    assert back.arcs == 0
    corner = back.breakpoints()[1]
    assert corner == pytest.approx(np.sqrt(2.0))
    # dq/ds reverses at the corner: a timing law must stop there
    np.testing.assert_allclose(
        back(np.array([corner - 1e-9]), 1), -back(np.array([corner + 1e-9]), 1)
    )
