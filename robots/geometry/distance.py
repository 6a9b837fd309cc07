"""Distances between a segment (a capsule's axis) and primitives, vectorized over any leading axes.

Closed forms where there are short ones (segment-segment: capsule-capsule and capsule-sphere); for a
box or a cylinder the minimum over the segment of the shape's signed distance function, which is
convex along the segment, found by golden-section search (48 steps: < 1e-9 of the segment's length).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
_GOLDEN_STEPS = 48


def segment_segment(
    a1: np.ndarray, b1: np.ndarray, a2: np.ndarray, b2: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest points of segments ``a1-b1`` and ``a2-b2`` (broadcast ``(..., 3)``): (distance, p1, p2).

    Ericson, Real-Time Collision Detection, 5.1.9, vectorized; degenerate segments (points) included.
    """
    d1, d2, r = b1 - a1, b2 - a2, a1 - a2
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    eps = 1e-18
    denom = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(
            denom > eps * np.maximum(a * e, eps), np.clip((b * f - c * e) / denom, 0, 1), 0.0
        )
        t = np.where(e > eps, (b * s + f) / np.where(e > eps, e, 1.0), 0.0)
        s_lo = np.where(a > eps, np.clip(-c / np.where(a > eps, a, 1.0), 0, 1), 0.0)
        s_hi = np.where(a > eps, np.clip((b - c) / np.where(a > eps, a, 1.0), 0, 1), 0.0)
    s = np.where((t < 0) | (e <= eps), s_lo, np.where(t > 1, s_hi, s))
    t = np.clip(t, 0, 1)
    p1 = a1 + s[..., None] * d1
    p2 = a2 + t[..., None] * d2
    return np.linalg.norm(p1 - p2, axis=-1), p1, p2


def sdf_box(x: np.ndarray, half: np.ndarray) -> np.ndarray:
    q = np.abs(x) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
    return outside + np.minimum(q.max(axis=-1), 0.0)


def sdf_cylinder(x: np.ndarray, radius: np.ndarray, half_length: np.ndarray) -> np.ndarray:
    q = np.stack(
        [np.linalg.norm(x[..., :2], axis=-1) - radius, np.abs(x[..., 2]) - half_length], axis=-1
    )
    return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)


def segment_sdf_min(
    a: np.ndarray, b: np.ndarray, sdf: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """min over the segment ``a-b`` (..., 3) of a convex signed distance function ``sdf(x)``
    (golden-section search, vectorized)."""
    lo = np.zeros(a.shape[:-1])
    hi = np.ones(a.shape[:-1])
    d = b - a

    def f(t: np.ndarray) -> np.ndarray:
        return sdf(a + t[..., None] * d)

    x1 = hi - _GOLDEN * (hi - lo)
    x2 = lo + _GOLDEN * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(_GOLDEN_STEPS):
        left = f1 < f2  # the minimum lies in [lo, x2]
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x1n = np.where(left, hi - _GOLDEN * (hi - lo), x2)
        x2n = np.where(left, x1, lo + _GOLDEN * (hi - lo))
        fn = f(np.where(left, x1n, x2n))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = x1n, x2n
    ends = np.minimum(f(np.zeros_like(lo)), f(np.ones_like(lo)))
    return np.minimum(np.minimum(f1, f2), ends)
