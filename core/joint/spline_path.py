"""A geometric joint path through waypoints: the C2 cubic spline in a chord-length path parameter.

``SplinePath`` implements ``core.timing.joint_path.JointPath`` for the retime endpoint's
``"path": "spline"``: q(s) passes through every waypoint, s is the cumulative joint-space chord
length (s_k = sum of |q_k - q_{k-1}| over the previous waypoints, [rad or m]), and the cubic has
scipy's ``not-a-knot`` ends (the first two and the last two pieces are one cubic each; with two
waypoints the straight line, with three the parabola through them), so it is C2 everywhere and its
derivatives with respect to s are exact (polynomial pieces). The waypoints are the knots; d2q/ds2 is
continuous there, so the only breakpoints are the ends, and the knots are the path's ``joins``
(``JoinedPath``: a timing law checks its limits there rather than putting them in its grid). Units: waypoints ``(n, dof)`` [rad or m].
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline


class SplinePath:
    """q(s), s in [0, ``length``], through ``waypoints`` ``(n, dof)`` (n >= 2, consecutive ones
    distinct: ``core.joint.waypoints.check_waypoints``) at their chord-length parameters."""

    def __init__(self, waypoints: np.ndarray) -> None:
        q = np.asarray(waypoints, dtype=float)
        chords = np.linalg.norm(np.diff(q, axis=0), axis=1)
        self.knots = np.concatenate([[0.0], np.cumsum(chords)])
        self.length = float(self.knots[-1])
        self.dof = int(q.shape[1])
        self._spline = CubicSpline(self.knots, q, bc_type="not-a-knot", axis=0)

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q [rad or m] (``order=0``), dq/ds (1), d2q/ds2 (2) or d3q/ds3 (3) at ``s`` ``(K,)``
        (clipped to [0, length]): ``(K, dof)``."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        return np.asarray(self._spline(s, nu=order))

    def breakpoints(self) -> np.ndarray:
        """``[0, length]``: d2q/ds2 is continuous at the knots, so a timing grid need not hold
        them (``joins``)."""
        return np.array([0.0, self.length])

    def joins(self) -> np.ndarray:
        """The knots ``(n,)``, where d3q/ds3 jumps (``core.timing.joint_path.JoinedPath``)."""
        return self.knots.copy()
