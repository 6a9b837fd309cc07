"""Point-to-point joint profiles: linear, cubic, quintic, trapezoidal, for any number of joints.

Each profile is built once and sampled many times: ``profile(t, order)`` -> ``(len(t), dof)`` for
``order`` 0, 1, 2 (positions, velocities, accelerations) at times ``t`` in [s] within ``[0, T]``.
Cubic and quintic follow the course notes: the boundary-condition matrix is solved on normalized
time ``s = t / T``, where boundary velocities scale by ``T`` and accelerations by ``T^2``;
derivatives scale back by ``1/T`` and ``1/T^2``. At ``t == 0`` and ``t == T`` every profile
returns its boundary conditions exactly (not as polynomial round-off), so a rest-to-rest plan ends
at exactly zero speed.
"""

from __future__ import annotations

import numpy as np

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
_CUBIC_INVERSE = np.linalg.inv(CUBIC_MATRIX)
_QUINTIC_INVERSE = np.linalg.inv(QUINTIC_MATRIX)


def polyval(coeffs: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Horner evaluation; ``coeffs`` ``(m, ...)`` highest power first, ``s`` broadcast to it."""
    out = np.zeros(np.broadcast_shapes(coeffs.shape[1:], np.shape(s)))
    for c in coeffs:
        out = out * s + c
    return out


def polyder(coeffs: np.ndarray, order: int = 1) -> np.ndarray:
    """Coefficients ``(m - order, ...)`` of the ``order``-th derivative (at least one row)."""
    for _ in range(order):
        m = coeffs.shape[0]
        if m == 1:
            return np.zeros_like(coeffs)
        powers = np.arange(m - 1, 0, -1, dtype=float).reshape((-1,) + (1,) * (coeffs.ndim - 1))
        coeffs = coeffs[:-1] * powers
    return coeffs


def _quadratic_roots(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Real roots of ``a x^2 + b x + c`` (linear when ``a == 0``), ``(2, ...)``, NaN where none."""
    with np.errstate(all="ignore"):
        disc = b * b - 4.0 * a * c
        q = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
        roots = np.stack([q / a, c / q])
    return np.where(np.isfinite(roots) & (disc >= 0.0), roots, np.nan)


def unit_roots(coeffs: np.ndarray, iterations: int = 60) -> np.ndarray:
    """Real roots in ``[0, 1]`` of polynomials of degree <= 3, vectorized over trailing axes.

    Degree <= 2 in closed form. A cubic's critical points (closed form) split ``[0, 1]`` into at
    most three monotone pieces; a root in a piece with a sign change is found by Newton steps kept
    inside the bracket, with bisection when a step leaves it or fails to halve the previous one
    ("rtsafe"). Returns ``(3, ...)``, NaN-padded.
    """
    c = np.concatenate([np.zeros((4 - coeffs.shape[0], *coeffs.shape[1:])), coeffs])
    if not np.any(c[0]):
        roots = _quadratic_roots(c[1], c[2], c[3])
        roots = np.where((roots >= 0.0) & (roots <= 1.0), roots, np.nan)
        return np.concatenate([roots, np.full((1, *roots.shape[1:]), np.nan)])
    cuts = np.nan_to_num(np.clip(_quadratic_roots(3.0 * c[0], 2.0 * c[1], c[2]), 0.0, 1.0))
    zeros, ones = np.zeros_like(c[0]), np.ones_like(c[0])
    edges = np.sort(np.concatenate([zeros[None], cuts, ones[None]]), axis=0)
    lo, hi = edges[:-1], edges[1:]
    cc, dc = c[:, None], polyder(c)[:, None]
    p_lo = polyval(cc, lo)
    bracketed = p_lo * polyval(cc, hi) <= 0.0
    x, moved = 0.5 * (lo + hi), hi - lo
    for _ in range(iterations):
        px = polyval(cc, x)
        right = np.sign(px) == np.sign(p_lo)
        lo, p_lo, hi = np.where(right, x, lo), np.where(right, px, p_lo), np.where(right, hi, x)
        with np.errstate(all="ignore"):
            newton = x - px / polyval(dc, x)
        step = np.abs(newton - x)
        converged = (px == 0.0) | (step <= 1e-14)  # s is in [0, 1]: an absolute tolerance
        fast = (newton >= lo) & (newton <= hi) & (2.0 * step <= moved)
        nxt = np.where(fast, newton, 0.5 * (lo + hi))
        nxt = np.where(converged, np.clip(np.where(px == 0.0, x, newton), lo, hi), nxt)
        moved, x = np.abs(nxt - x), nxt
        if np.all(converged | ~bracketed):
            break
    return np.where(bracketed, x, np.nan)


def abs_peak_on_unit(coeffs: np.ndarray) -> np.ndarray:
    """``max |p(s)|`` over ``s`` in ``[0, 1]`` for degree <= 4, exact up to round-off; ``(...)``."""
    crit = unit_roots(polyder(coeffs))
    ends = np.stack([np.zeros(coeffs.shape[1:]), np.ones(coeffs.shape[1:])])
    cand = np.concatenate([ends, np.nan_to_num(crit, nan=0.0)])
    return np.abs(polyval(coeffs[:, None], cand)).max(axis=0)


class _EndPinned:
    """Shared sampling: profile-specific values, with the exact boundary conditions at 0 and T."""

    duration: float
    _start: tuple[np.ndarray | None, ...]
    _goal: tuple[np.ndarray | None, ...]

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = self._evaluate(t, order)
        if order < len(self._start):
            for mask, value in (
                (t == 0.0, self._start[order]),
                (t == self.duration, self._goal[order]),
            ):
                if value is not None:
                    out[mask] = value
        return out

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        raise NotImplementedError


class PolynomialProfile(_EndPinned):
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
        T = np.asarray(duration, dtype=float)
        self.duration = float(T) if T.ndim == 0 else np.nan
        self._T = T
        if a0 is None or a1 is None:
            rhs = np.stack(np.broadcast_arrays(q0, v0 * T, q1, v1 * T))
            self.coeffs = np.tensordot(_CUBIC_INVERSE, rhs, axes=1)
            self._start, self._goal = (q0, v0, None), (q1, v1, None)
        else:
            rhs = np.stack(np.broadcast_arrays(q0, q1, v0 * T, v1 * T, a0 * T**2, a1 * T**2))
            self.coeffs = np.tensordot(_QUINTIC_INVERSE, rhs, axes=1)
            self._start, self._goal = (q0, v0, a0), (q1, v1, a1)
        self.method = "cubic" if a0 is None else "quintic"

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        s = (t / self.duration)[:, None]
        return polyval(polyder(self.coeffs, order), s) / self.duration**order

    def peaks(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact largest |velocity| and |acceleration| over ``[0, T]``, each ``(..., dof)``."""
        vel = abs_peak_on_unit(polyder(self.coeffs, 1)) / self._T
        acc = abs_peak_on_unit(polyder(self.coeffs, 2)) / self._T**2
        return vel, acc


class LinearProfile(_EndPinned):
    """Constant velocity ``dq / T`` from ``q0`` to ``q1``; accelerations are reported as zero.

    Honest about the ends: the true velocity steps from 0 to ``dq / T`` at ``t = 0`` and back to 0
    at ``t = T`` (unbounded acceleration there). The samples at ``t == 0`` and ``t == T`` report the
    rest state (velocity exactly 0), because the ROS 2 joint trajectory controller requires zero
    velocity at the last point of a rest-to-rest plan; interior samples report ``dq / T``.
    """

    method = "linear"

    def __init__(self, q0: np.ndarray, q1: np.ndarray, duration: float) -> None:
        self.duration = float(duration)
        self.q0, self.dq = q0, q1 - q0
        zero = np.zeros_like(q0)
        self._start, self._goal = (q0, zero, zero), (q1, zero, zero)

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        s = (t / self.duration)[:, None]
        if order == 0:
            return self.q0 + self.dq * s
        if order == 1:
            return np.broadcast_to(self.dq / self.duration, (t.size, self.dq.size)).copy()
        return np.zeros((t.size, self.dq.size))

    def peaks(self) -> tuple[np.ndarray, np.ndarray]:
        """Cruise speed ``|dq| / T`` and zero (the end steps are not counted), each ``(dof,)``."""
        return np.abs(self.dq) / self.duration, np.zeros_like(self.dq)


class TrapezoidalProfile(_EndPinned):
    """Synchronized trapezoidal velocity, rest to rest: every joint starts and ends with the others.

    Each joint accelerates at ``a_j`` for ``ta_j``, cruises at ``v_j`` and decelerates for ``ta_j``,
    with ``v_j = 2|dq_j| / (T + sqrt(T^2 - 4|dq_j|/a_j))`` (the lower cruise speed that covers
    ``|dq_j|`` in ``T``; a triangle when ``T^2 = 4|dq_j|/a_j``). The joint-space path is therefore
    not a straight line. Accelerations are piecewise constant: at a switch the sample reports the
    phase that starts there, and at ``t == T`` the deceleration.

    Args:
        q0, q1: Start and goal positions ``(dof,)``.
        duration: ``T`` in [s].
        acceleration: ``a_j`` ``(dof,)`` [rad/s^2 or m/s^2]; ``inf`` entries (unknown limit) use
            ``4.5 |dq| / T^2`` (ramps of ``T/3``). An ``a_j`` too small to cover ``|dq_j|`` in
            ``T`` is raised to the triangle's ``4 |dq_j| / T^2``: check ``peaks()`` against limits.
    """

    method = "trapezoidal"

    def __init__(
        self, q0: np.ndarray, q1: np.ndarray, duration: float, acceleration: np.ndarray
    ) -> None:
        T = self.duration = float(duration)
        dist = np.abs(q1 - q0)
        acc = np.where(np.isfinite(acceleration), acceleration, 4.5 * dist / T**2)
        acc = np.where(dist > 0.0, np.maximum(acc, 4.0 * dist / T**2), 0.0)
        ratio = np.divide(dist, acc, out=np.zeros_like(dist), where=acc > 0.0)
        root = np.sqrt(np.maximum(T**2 - 4.0 * ratio, 0.0))
        self.cruise = 2.0 * dist / (T + root)
        self.ramp = np.divide(self.cruise, acc, out=np.zeros_like(dist), where=acc > 0.0)
        self.acceleration = acc
        self.q0, self.q1, self.sign = q0, q1, np.sign(q1 - q0)
        zero = np.zeros_like(q0)
        self._start, self._goal = (q0, zero), (q1, zero)

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        T, ta, v, a, sg = self.duration, self.ramp, self.cruise, self.acceleration, self.sign
        tt = np.clip(t, 0.0, T)[:, None]
        rising, falling = tt < ta, tt >= T - ta
        if order == 0:
            up = self.q0 + sg * 0.5 * a * tt**2
            cruise = self.q0 + sg * (0.5 * a * ta**2 + v * (tt - ta))
            down = self.q1 - sg * 0.5 * a * (T - tt) ** 2
        elif order == 1:
            up, cruise, down = sg * a * tt, sg * v + 0.0 * tt, sg * a * (T - tt)
        else:
            up, cruise, down = sg * a + 0.0 * tt, 0.0 * tt + 0.0 * sg, -sg * a + 0.0 * tt
        return np.where(rising, up, np.where(falling, down, cruise))

    def peaks(self) -> tuple[np.ndarray, np.ndarray]:
        """Cruise speed and acceleration of each joint, each ``(dof,)``."""
        return self.cruise.copy(), self.acceleration.copy()
