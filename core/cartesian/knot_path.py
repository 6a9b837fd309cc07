"""Knots of the bounded-deviation methods and the C2 joint path through them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline


@dataclass(frozen=True)
class Knots:
    """Knots of a bounded-deviation plan.

    Attributes:
        s: Path parameter of each knot, increasing from 0 to 1, shape ``(K,)``.
        positions: Joint positions of each knot, ``(K, dof)``.
    """

    s: np.ndarray
    positions: np.ndarray

    def __len__(self) -> int:
        return len(self.s)

    def insert(self, s: np.ndarray, positions: np.ndarray) -> Knots:
        """These knots plus new ones (path parameters ``s`` (n,), joints ``(n, dof)``), sorted."""
        all_s = np.concatenate([self.s, s])
        order = np.argsort(all_s, kind="stable")
        return Knots(all_s[order], np.vstack([self.positions, positions])[order])


class KnotPath:
    """The joint path through knots: q(s), a C2 cubic spline in s (not-a-knot; a line for 2 knots).

    Args:
        knots: The knots; ``s`` strictly increasing from 0 to 1.
    """

    def __init__(self, knots: Knots) -> None:
        self.knots = knots
        self._spline = CubicSpline(knots.s, knots.positions, axis=0, bc_type="not-a-knot")

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q (order 0), dq/ds (1) or d2q/ds2 (2) at path parameters ``s`` (N,): (N, dof)."""
        return self._spline(np.clip(np.asarray(s, dtype=float), 0.0, 1.0), order)

    def segment_of(self, s: np.ndarray) -> np.ndarray:
        """Index of the knot segment holding each path parameter in ``s`` (N,)."""
        k = np.searchsorted(self.knots.s, s, side="right") - 1
        return np.clip(k, 0, len(self.knots) - 2)
