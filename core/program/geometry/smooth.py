"""The one interpolating spline of a program's joint path: C2 cubic (scipy ``CubicSpline``).

Through the dense joint samples of a segment or a chunk (IK solutions on the path, blends), the
not-a-knot cubic spline is C2: with the path's C2 blends (``core.program.geometry.blend``) the
program's joint path q(s) is C2 everywhere. Higher-order splines ring between the unevenly spaced
samples where a blend meets a segment (a quintic spline made the acceleration swing by several
rad/s^2 every 10 ms through a blend); the returned motion's exact derivatives come from the cubic
in time through the returned points (``core.program.returned``), not from the path's smoothness.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline


def smooth_spline(x: np.ndarray, y: np.ndarray) -> CubicSpline:
    """The spline through ``(x, y)``: ``x`` ``(K,)`` strictly increasing (K >= 2), ``y``
    ``(K, dof)``; ``spline(x, nu)`` is its ``nu``-th derivative ``(N, dof)``."""
    return CubicSpline(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
