"""``BlendedPath``: a ``JointPath`` with exact derivatives (finite differences), unit speed in its
arc-length parameter, continuous position and direction across every breakpoint, blends within
their deviation of the corner, and stops at the corners left sharp."""

from __future__ import annotations

import numpy as np
import pytest

from core.joint.blended_path import BlendedPath
from core.timing.joint_path import JointPath

KNOTS = np.array(
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [1.2, 0.9, 0.1], [0.3, 1.1, -0.4], [0.2, 1.5, 0.0]]
)


@pytest.mark.parametrize("deviation", [0.0, 0.02, 0.3])
def test_a_joint_path_with_exact_derivatives(deviation: float) -> None:
    path = BlendedPath(KNOTS, np.full(len(KNOTS), deviation))
    assert isinstance(path, JointPath) and path.dof == 3
    b = path.breakpoints()
    assert b[0] == 0.0 and b[-1] == pytest.approx(path.length) and np.all(np.diff(b) > 0)
    # inside every piece: derivatives against central differences
    mids = (b[:-1] + b[1:]) / 2
    h = 1e-6
    for order in (1, 2):
        fd = (path(mids + h, order - 1) - path(mids - h, order - 1)) / (2 * h)
        np.testing.assert_allclose(path(mids, order), fd, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(path(mids, 1), axis=1), 1.0, atol=1e-12)
    # continuity of q everywhere, of dq/ds wherever the path does not stop
    eps = 1e-9
    inner = b[1:-1]
    np.testing.assert_allclose(path(inner - eps), path(inner + eps), atol=1e-8)
    moving = np.array([not np.any(np.isclose(s, path.stops())) for s in inner])
    np.testing.assert_allclose(
        path(inner[moving] - eps, 1), path(inner[moving] + eps, 1), atol=1e-6
    )
    np.testing.assert_allclose(path(np.array([0.0, path.length])), KNOTS[[0, -1]], atol=1e-12)


def test_blends_stay_within_their_deviation() -> None:
    path = BlendedPath(KNOTS, np.full(len(KNOTS), 0.05))
    s = np.linspace(0.0, path.length, 20001)
    q = path(s)
    for k in range(1, len(KNOTS) - 1):
        near = np.linalg.norm(q - KNOTS[k], axis=1).min()
        assert near <= 0.05 + 1e-6  # the arc middle is exactly 0.05 away (sampled: a hair more)
    assert path.length < np.linalg.norm(np.diff(KNOTS, axis=0), axis=1).sum()


def test_sharp_corners_are_stops() -> None:
    dev = np.array([0.0, 0.0, 0.05, 0.0, 0.0])
    path = BlendedPath(KNOTS, dev)
    stops = path.stops()
    assert len(stops) == 2  # knots 1 and 3 stay sharp
    np.testing.assert_allclose(path(stops), KNOTS[[1, 3]], atol=1e-12)
    assert len(BlendedPath(KNOTS).stops()) == 3
