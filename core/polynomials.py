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

import functools

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
    p_lo, p_hi = polyval(cc, lo), polyval(cc, hi)
    bracketed = p_lo * p_hi <= 0.0
    # |p| below the round-off of evaluating p on [0, 1] is a root. A bracket's end that is one (a
    # rest-to-rest profile's, at s = 0 and s = 1) is taken as is: Newton steps from inside overshoot
    # it, and bisection would take ~45 halvings to reach the step tolerance.
    noise = 8.0 * np.finfo(float).eps * np.abs(c).sum(axis=0)
    x = np.where(np.abs(p_lo) <= noise, lo, np.where(np.abs(p_hi) <= noise, hi, 0.5 * (lo + hi)))
    moved = hi - lo
    for _ in range(iterations):
        px = polyval(cc, x)
        right = np.sign(px) == np.sign(p_lo)
        lo, p_lo, hi = np.where(right, x, lo), np.where(right, px, p_lo), np.where(right, hi, x)
        with np.errstate(all="ignore"):
            newton = x - px / polyval(dc, x)
        step = np.abs(newton - x)
        converged = (np.abs(px) <= noise) | (step <= 1e-14)  # s in [0, 1]: absolute tolerances
        fast = (newton >= lo) & (newton <= hi) & (2.0 * step <= moved)
        nxt = np.where(fast, newton, 0.5 * (lo + hi))
        nxt = np.where(converged, np.clip(np.where(np.abs(px) <= noise, x, newton), lo, hi), nxt)
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
    return (inverse @ rhs.reshape(rhs.shape[0], -1)).reshape(rhs.shape)


class _EndPinned:
    """Shared sampling: profile-specific values, with the exact boundary conditions at 0 and T."""

    duration: float
    _start: tuple[np.ndarray | None, ...]
    _goal: tuple[np.ndarray | None, ...]

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return self._pin(self._ends(t), order, self._evaluate(t, order))

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations at ``t`` ``(N,)``, each ``(N, dof)``: the same as
        three calls, sharing the work they have in common."""
        t = np.asarray(t, dtype=float)
        ends = self._ends(t)
        q, qd, qdd = self._evaluate_orders(t)
        return self._pin(ends, 0, q), self._pin(ends, 1, qd), self._pin(ends, 2, qdd)

    def _evaluate_orders(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        return tuple(self._evaluate(t, order) for order in range(3))

    def _ends(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Indices of the samples at exactly 0 and exactly ``T``."""
        return (t == 0.0).nonzero()[0], (t == self.duration).nonzero()[0]

    def _pin(self, ends: tuple[np.ndarray, np.ndarray], order: int, out: np.ndarray) -> np.ndarray:
        if order < len(self._start):
            for hit, value in zip(ends, (self._start[order], self._goal[order]), strict=True):
                if value is not None and hit.size:
                    out[hit] = value
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
        stack = np.array if T.ndim == 0 else lambda rows: np.stack(np.broadcast_arrays(*rows))
        if a0 is None or a1 is None:
            rhs = stack([q0, v0 * T, q1, v1 * T])
            self.coeffs = _solve(_CUBIC_INVERSE, rhs)
            self._start, self._goal = (q0, v0, None), (q1, v1, None)
        else:
            rhs = stack([q0, q1, v0 * T, v1 * T, a0 * T**2, a1 * T**2])
            self.coeffs = _solve(_QUINTIC_INVERSE, rhs)
            self._start, self._goal = (q0, v0, a0), (q1, v1, a1)
        self.method = "cubic" if a0 is None else "quintic"

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        return self._evaluate_powers(self._powers(t), order)

    def _evaluate_orders(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        # Each order is one (N, m) @ (m, dof) product on the shared powers, written C-contiguous
        # (N, dof): the derivatives' coefficients, divided by T^order, padded with leading zeros
        # to line up with the powers.
        m = self.coeffs.shape[0]
        T = self.duration
        scaled = (
            _derivatives(m) * np.array([1.0, 1.0 / T, 1.0 / T**2])[:, None, None]
        ) @ self.coeffs
        powers = self._powers(t).T
        return tuple(powers @ scaled[order] for order in range(3))

    def _powers(self, t: np.ndarray) -> np.ndarray:
        """Powers of ``s = t / T`` as ``(m, N)`` rows, highest first (the long axis innermost)."""
        s = t / self.duration
        m = self.coeffs.shape[0]
        powers = np.empty((m, s.size))
        powers[m - 1] = 1.0
        for i in range(m - 2, -1, -1):
            np.multiply(powers[i + 1], s, out=powers[i])
        return powers

    def _evaluate_powers(self, powers: np.ndarray, order: int) -> np.ndarray:
        # One (N, m) @ (m, dof) product: several times faster than Horner on (N, dof) for
        # N >> dof, and equal to it within ~1e-15.
        out = powers[order:].T @ polyder(self.coeffs, order)
        out /= self.duration**order
        return out

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
