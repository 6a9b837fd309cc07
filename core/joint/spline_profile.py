"""``SplineProfile``: a C2 cubic spline q(t) through waypoints at knot times (scipy's
``CubicSpline``, one boundary condition per end), built once and sampled often, with its exact
peaks. ``core.joint.splines`` allocates its knot times and plans with it.

Units: positions [rad or m], times [s]; waypoints ``(n + 1, dof)``, knot times ``(n + 1,)``.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from core.trajectory import Peaks

BOUNDARIES = ("clamped", "natural", "not-a-knot")
SAMPLE_BLOCK = 2048
"""Samples evaluated at once by ``SplineProfile.sample`` (its temporaries stay in cache)."""


class SplineProfile:
    """A C2 cubic spline ``q(t)`` through ``waypoints`` at ``knot_times``: build once, sample often.

    Args:
        knot_times: ``(n + 1,)`` in [s], strictly increasing from 0.
        waypoints: ``(n + 1, dof)``.
        boundary: One of ``BOUNDARIES``.
        start_velocity, goal_velocity: ``(dof,)`` end velocities of a ``clamped`` spline.
    """

    method = "spline"

    def __init__(
        self,
        knot_times: np.ndarray,
        waypoints: np.ndarray,
        boundary: str = "clamped",
        start_velocity: np.ndarray | None = None,
        goal_velocity: np.ndarray | None = None,
    ) -> None:
        dof = waypoints.shape[1]
        v0 = np.zeros(dof) if start_velocity is None else start_velocity
        v1 = np.zeros(dof) if goal_velocity is None else goal_velocity
        bc = ((1, v0), (1, v1)) if boundary == "clamped" else boundary
        self.spline = CubicSpline(knot_times, waypoints, bc_type=bc, axis=0)
        self._coeffs = np.ascontiguousarray(self.spline.c.transpose(0, 2, 1))  # (4, dof, n)
        self.knot_times, self.boundary = knot_times, boundary
        self.duration = float(knot_times[-1])
        zero = np.zeros(dof) if boundary == "natural" else None
        clamped = boundary == "clamped"
        self._ends = (
            (0.0, (waypoints[0], v0 if clamped else None, zero)),
            (self.duration, (waypoints[-1], v1 if clamped else None, zero)),
        )

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """Derivative ``order`` at times ``t`` ``(N,)`` -> ``(N, dof)``; exact at the ends."""
        t = np.asarray(t, dtype=float)
        return self._pin(self._hits(t), order, np.asarray(self.spline(t, nu=order)))

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations at ``t`` ``(N,)``, each ``(N, dof)``: the same as
        three calls (to ~1e-15), with one interval search and Horner's rule on ``(dof, N)`` rows
        in blocks of ``SAMPLE_BLOCK`` samples (the working set stays in cache): faster than
        scipy's three evaluations."""
        t = np.asarray(t, dtype=float)
        knots = self.knot_times
        k = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
        x = t - knots[k]
        n, dof = t.size, self._coeffs.shape[1]
        q, qd, qdd = np.empty((3, n, dof))  # one allocation: large ones cost page faults
        for lo in range(0, n, SAMPLE_BLOCK):
            hi = min(n, lo + SAMPLE_BLOCK)
            xs = x[lo:hi]
            a, b, c, d = np.take(self._coeffs, k[lo:hi], axis=2)  # each (dof, hi - lo)
            # Horner with its derivatives: p = a x + b, then p x + c (=: r), q = r x + d;
            # qd = (a x + p) x + r = 3a x^2 + 2b x + c; qdd = 2 (a x + p + a x) = 6a x + 2b.
            # Rows are (dof, block) (the long axis innermost), copied into the (N, dof) outputs.
            ax = a * xs
            p = ax + b
            dp = ax + p
            acc = dp + ax
            acc *= 2.0
            p *= xs
            p += c
            pos = p * xs
            pos += d
            dp *= xs
            dp += p
            q[lo:hi], qd[lo:hi], qdd[lo:hi] = pos.T, dp.T, acc.T
        hits = self._hits(t)
        return self._pin(hits, 0, q), self._pin(hits, 1, qd), self._pin(hits, 2, qdd)

    def _hits(self, t: np.ndarray) -> list[np.ndarray]:
        """Indices of the samples at exactly each end (0 and the duration)."""
        return [(t == at).nonzero()[0] for at, _ in self._ends]

    def _pin(self, hits: list[np.ndarray], order: int, out: np.ndarray) -> np.ndarray:
        for hit, (_, values) in zip(hits, self._ends, strict=True):
            if order < len(values) and values[order] is not None and hit.size:
                out[hit] = values[order]
        return out

    def segment_peaks(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact largest |velocity| and |acceleration| on each piece, each ``(n, dof)``.

        On a piece ``c0 x^3 + c1 x^2 + c2 x + c3``, ``x`` in ``[0, h]``: the velocity peaks at an
        end or at ``x* = -c1 / (3 c0)``; the acceleration is linear, so it peaks at an end.
        """
        c0, c1, c2 = self.spline.c[0], self.spline.c[1], self.spline.c[2]
        h = np.diff(self.knot_times)[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = -c1 / (3.0 * c0)
            inside = np.isfinite(x) & (x > 0.0) & (x < h)
            v_mid = np.where(inside, np.abs(c2 - c1**2 / (3.0 * c0)), 0.0)
        v_end = np.abs(3.0 * c0 * h**2 + 2.0 * c1 * h + c2)
        vel = np.maximum(np.maximum(np.abs(c2), v_end), v_mid)
        acc = np.maximum(np.abs(2.0 * c1), np.abs(6.0 * c0 * h + 2.0 * c1))
        return vel, acc

    def peaks(self) -> Peaks:
        """Exact largest |velocity|, |acceleration| and |jerk| (``6 |c0|``, constant on each
        piece) over the whole spline, each ``(dof,)``."""
        vel, acc = self.segment_peaks()
        return Peaks(vel.max(axis=0), acc.max(axis=0), np.abs(6.0 * self.spline.c[0]).max(axis=0))

    def switch_times(self) -> np.ndarray:
        """The inner knot times [s], where the jerk steps."""
        return self.knot_times[1:-1].copy()
