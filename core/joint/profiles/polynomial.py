"""Cubic and quintic point-to-point profiles (registry entries ``cubic`` and ``quintic``).

Built once and sampled many times: ``profile(t, order)`` -> ``(len(t), dof)`` for ``order`` 0, 1, 2
(positions, velocities, accelerations) at times ``t`` in [s] within ``[0, T]``. Both follow the
course notes: the boundary-condition matrix is solved on normalized
time ``s = t / T``, where boundary velocities scale by ``T`` and accelerations by ``T^2``;
derivatives scale back by ``1/T`` and ``1/T^2``. At ``t == 0`` and ``t == T`` the profile
returns its boundary conditions exactly (not as polynomial round-off), so a rest-to-rest plan ends
at exactly zero speed.
"""

from __future__ import annotations

import functools

import numpy as np

from core.errors import JointRateLimit
from core.joint import durations
from core.joint.motion import PointToPoint
from core.joint.peaks import abs_peak_on_unit, polyder
from core.joint.profiles.base import DurationProfileKind, EndPinned
from core.limits import JointLimits
from core.trajectory import Peaks

CUBIC_MATRIX = np.array([[0, 0, 0, 1], [0, 0, 1, 0], [1, 1, 1, 1], [3, 2, 1, 0]], dtype=float)
"""Notes eq. (1): rows (q0, v0, q1, v1) of ``q(s) = a s^3 + b s^2 + c s + d``."""
QUINTIC_MATRIX = np.array(
    [
        [0, 0, 0, 0, 0, 1],
        [1, 1, 1, 1, 1, 1],
        [0, 0, 0, 0, 1, 0],
        [5, 4, 3, 2, 1, 0],
        [0, 0, 0, 2, 0, 0],
        [20, 12, 6, 2, 0, 0],
    ],
    dtype=float,
)
"""Notes eq. (3): rows (q0, q1, v0, v1, a0, a1) of the quintic, coefficients highest power first."""
REST_PEAKS = {"cubic": (1.5, 6.0, 12.0), "quintic": (15.0 / 8.0, 10.0 / np.sqrt(3.0), 60.0)}
"""Rest to rest: peaks of the velocity, acceleration and jerk in units of ``|dq| / T^k`` (cubic
``3s^2 - 2s^3``; quintic ``10s^3 - 15s^4 + 6s^5``: velocity at s = 1/2, acceleration at
s = 1/2 -+ sqrt(3)/6, jerk at both ends)."""
_CUBIC_INVERSE = np.linalg.inv(CUBIC_MATRIX)
_QUINTIC_INVERSE = np.linalg.inv(QUINTIC_MATRIX)


_REST_COLUMNS = {name: np.array(k)[:, None] for name, k in REST_PEAKS.items()}


@functools.cache
def _derivatives(m: int) -> np.ndarray:
    """``(3, m, m)``: coefficients (highest power first) of a degree ``m - 1`` polynomial to those of
    its value, first and second derivatives, each padded with leading zeros to ``m`` rows."""
    out = np.zeros((3, m, m))
    for order in range(3):
        out[order, order:] = polyder(np.eye(m), order)
    out.flags.writeable = False
    return out


def _solve(inverse: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``tensordot(inverse, rhs, axes=1)``: coefficients ``(m, ...)`` from boundary values."""
    if rhs.ndim == 2:
        return inverse @ rhs
    return (inverse @ rhs.reshape(rhs.shape[0], -1)).reshape(rhs.shape)


class PolynomialProfile(EndPinned):
    """Cubic (4 conditions) or quintic (6 conditions) through the notes' boundary-condition matrix.

    Args:
        q0, q1: Start and goal positions ``(dof,)`` [rad or m].
        duration: ``T`` in [s]; a float, or ``(G, 1)`` for ``G`` candidates at once (``peaks``).
        v0, v1: Boundary velocities ``(dof,)`` [rad/s or m/s].
        a0, a1: Boundary accelerations ``(dof,)`` [rad/s^2 or m/s^2]; ``None`` makes a cubic.
    """

    def __init__(
        self,
        q0: np.ndarray,
        q1: np.ndarray,
        duration: float | np.ndarray,
        v0: np.ndarray,
        v1: np.ndarray,
        a0: np.ndarray | None = None,
        a1: np.ndarray | None = None,
    ) -> None:
        T: float | np.ndarray = (
            duration if isinstance(duration, float) else np.asarray(duration, dtype=float)
        )
        scalar = isinstance(T, float) or T.ndim == 0
        if scalar:
            T = float(T)  # a Python float multiplies arrays faster than a 0-d array
        self.duration = float(T) if scalar else np.nan
        self._T = T
        self._peaks: Peaks | None = None
        if scalar:
            # One stack and one scaling by (1, T, T^2) per row: the same products as scaling
            # each rate, in two array operations.
            if a0 is None or a1 is None:
                rhs = np.array([q0, v0, q1, v1]) * np.array([[1.0], [T], [1.0], [T]])
            else:
                T2 = T**2
                rhs = np.array([q0, q1, v0, v1, a0, a1]) * np.array(
                    [[1.0], [1.0], [T], [T], [T2], [T2]]
                )
        elif a0 is None or a1 is None:
            rhs = np.stack(np.broadcast_arrays(q0, v0 * T, q1, v1 * T))
        else:
            rhs = np.stack(np.broadcast_arrays(q0, q1, v0 * T, v1 * T, a0 * T**2, a1 * T**2))
        if a0 is None or a1 is None:
            self.coeffs = _solve(_CUBIC_INVERSE, rhs)
            self._start, self._goal = (q0, v0, None), (q1, v1, None)
            self._at_rest = not (np.count_nonzero(rhs[1]) or np.count_nonzero(rhs[3]))
        else:
            self.coeffs = _solve(_QUINTIC_INVERSE, rhs)
            self._start, self._goal = (q0, v0, a0), (q1, v1, a1)
            self._at_rest = not np.count_nonzero(rhs[2:])
        self.method = "cubic" if a0 is None else "quintic"

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        return self._evaluate_powers(self._powers(t), order)

    def _evaluate_orders(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        # The three orders are one stacked product (N, m) @ (3, m, dof) on the shared powers (one
        # call, numpy loops over the three BLAS products), written as three C-contiguous (N, dof)
        # blocks: the derivatives' coefficients, divided by T^order, padded with leading zeros to
        # line up with the powers.
        m = self.coeffs.shape[0]
        T = self.duration
        scaled = (
            _derivatives(m) * np.array([1.0, 1.0 / T, 1.0 / T**2])[:, None, None]
        ) @ self.coeffs
        out = self._powers(t).T @ scaled
        return out[0], out[1], out[2]

    def _powers(self, t: np.ndarray) -> np.ndarray:
        """Powers of ``s = t / T`` as ``(m, N)`` rows, highest first (the long axis innermost)."""
        m = self.coeffs.shape[0]
        powers = np.empty((m, t.size))
        powers[m - 1] = 1.0
        s = np.divide(t, self.duration, out=powers[m - 2])
        for i in range(m - 3, -1, -1):
            np.multiply(powers[i + 1], s, out=powers[i])
        return powers

    def _evaluate_powers(self, powers: np.ndarray, order: int) -> np.ndarray:
        # One (N, m) @ (m, dof) product: several times faster than Horner on (N, dof) for
        # N >> dof, and equal to it within ~1e-15.
        out = powers[order:].T @ polyder(self.coeffs, order)
        out /= self.duration**order
        return out

    def peaks(self) -> Peaks:
        """Exact largest |velocity|, |acceleration| and |jerk| over ``[0, T]``, each
        ``(..., dof)``: closed forms rest to rest (``REST_PEAKS``), else the extrema of the
        derivatives found by ``abs_peak_on_unit``. Computed once per profile."""
        if self._peaks is None:
            self._peaks = self._exact_peaks()
        return self._peaks

    def _exact_peaks(self) -> Peaks:
        if self._at_rest:
            dq = np.abs(self.coeffs[:-1].sum(axis=0))  # |q(1) - q(0)|
            T = self._T
            if np.ndim(T) == 0:  # the three peaks as one (3, dof) product and quotient
                rows = _REST_COLUMNS[self.method] * dq / np.array([[T], [T**2], [T**3]])
                return Peaks(rows[0], rows[1], rows[2])
            k = REST_PEAKS[self.method]
            return Peaks(k[0] * dq / T, k[1] * dq / T**2, k[2] * dq / T**3)
        vel = abs_peak_on_unit(polyder(self.coeffs, 1)) / self._T
        acc = abs_peak_on_unit(polyder(self.coeffs, 2)) / self._T**2
        jerk = abs_peak_on_unit(polyder(self.coeffs, 3)) / self._T**3
        return Peaks(vel, acc, jerk)


class _Polynomial(DurationProfileKind):
    """Cubic or quintic: closed-form shortest duration rest to rest, else a numeric search."""

    closed_form = staticmethod(durations.quintic_duration)

    def build(
        self, motion: PointToPoint, duration: float | np.ndarray, max_acceleration: np.ndarray
    ) -> PolynomialProfile:
        start, goal = motion.start, motion.goal
        quintic = "accelerations" in self.boundary_rates
        return PolynomialProfile(
            start.positions,
            goal.positions,
            duration,
            start.velocities,
            goal.velocities,
            start.accelerations if quintic else None,
            goal.accelerations if quintic else None,
        )

    def _shortest(self, motion: PointToPoint, limits: JointLimits) -> float:
        vmax, amax = limits.maxima(motion.dof)
        if motion.at_rest:
            return self.closed_form(motion.distance, vmax, amax)

        def excess(candidates: np.ndarray) -> np.ndarray:
            peaks = self.build(motion, candidates[:, None], amax).peaks()
            return np.maximum(peaks.velocity / vmax, peaks.acceleration / amax).max(axis=1) - 1.0

        found = durations.shortest_feasible(excess)
        if found is None:
            raise JointRateLimit(
                f"no {self.name} duration up to {durations.MAX_DURATION:g} s keeps every joint "
                "within its velocity and acceleration limits with these boundary conditions"
            )
        return found


class Cubic(_Polynomial):
    """Cubic: positions and velocities at both ends (accelerations jump at the ends)."""

    name = "cubic"
    boundary_rates = ("velocities",)
    closed_form = staticmethod(durations.cubic_duration)


class Quintic(_Polynomial):
    """Quintic: positions, velocities and accelerations at both ends."""

    name = "quintic"
    boundary_rates = ("velocities", "accelerations")
    closed_form = staticmethod(durations.quintic_duration)
