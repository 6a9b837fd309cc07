"""The returned motion of a rate controller: a C2 cubic spline through the returned points whose
velocities and accelerations are its exact derivatives, and which keeps the controller's velocity
and acceleration bounds at every instant.

The controller's joint velocity ``w(t)`` is continuous and piecewise linear (``tick_velocity``:
each tick's rate held as a ramp from the previous one, half a tick later; it starts and ends at
rest), so ``|w| <= v_max`` and ``|w'| <= a_max`` wherever the ticks respect them. The returned
velocity is Schoenberg's variation-diminishing quadratic spline of ``w`` on the returned times
``t_0 < ... < t_N`` (de Boor, A Practical Guide to Splines, 2001, ch. XI): the quadratic B-spline
with knots ``t_0, t_0, t_0, t_1, ..., t_{N-1}, t_N, t_N, t_N`` whose coefficients are ``w`` at the
knot averages (Greville abscissae) ``t_0, (t_0 + t_1)/2, ..., (t_{N-1} + t_N)/2, t_N``:

- ``v(t)`` is a convex combination of values of ``w``: ``|v| <= max |w|`` at every instant, and
  ``v(t_0) = w(t_0)``, ``v(t_N) = w(t_N)`` (rest at both ends);
- ``v'(t)`` is linear between consecutive returned times, a convex combination of the divided
  differences of ``w`` between consecutive knot averages, each a mean of ``w'``: ``|v'| <= max
  |w'|`` at every instant;
- linear ``w`` is reproduced exactly; otherwise ``v`` smooths ``w`` over about one interval, and
  the positions ``q(t) = q_0 + int v`` lie within about ``h^2/8`` times the change of ``w'`` of the
  controller's (``h``: the spacing of the returned times).

So between consecutive returned points the acceleration changes linearly from one point's value to
the next's (``q`` is a cubic there, C2 across the points): ``v_{i+1} = v_i + h (a_i + a_{i+1})/2``
and ``q_{i+1} = q_i + h v_i + h^2 (2 a_i + a_{i+1})/6`` hold exactly (to rounding).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.interpolate import BSpline


def greville(times: np.ndarray) -> np.ndarray:
    """The knot averages ``(N + 2,)`` of the quadratic spline on ``times`` ``(N + 1,)``."""
    return np.concatenate([times[:1], 0.5 * (times[:-1] + times[1:]), times[-1:]])


def smooth_motion(
    times: np.ndarray,
    velocity: Callable[[np.ndarray], np.ndarray],
    q0: np.ndarray,
    q_end: np.ndarray | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and accelerations ``(N, dof)`` at ``times`` ``(N,)`` [s] (strictly
    increasing, N >= 2) of the motion from ``q0`` ``(dof,)`` whose velocity is the Schoenberg
    spline of ``velocity`` (``(M,) -> (M, dof)``, [rad/s]) on ``times`` (the module docstring).

    With ``q_end`` (dof,) the motion ends there exactly where that keeps every velocity and
    acceleration within ``limits`` ``(v_max, a_max)`` (each (dof,); None: within the bounds
    above): the smoothing's net displacement error ``e`` (about ``h^2/8`` times the change of
    acceleration, integrated) is taken out by a half sine over the motion added to the
    coefficients (zero at both ends, which keep the rest): a velocity change of at most about
    ``1.6 e / duration`` and an acceleration change of about ``5 e / duration^2``. A joint whose
    limits that would break keeps its error
    (a joint at its velocity limit throughout, or a coarse braked prefix)."""
    times = np.asarray(times, dtype=float)
    knots = np.concatenate([times[:1], times[:1], times, times[-1:], times[-1:]])
    coefficients = velocity(greville(times))
    spline = BSpline(knots, coefficients, 2, extrapolate=False)
    positions = spline.antiderivative()(times) + q0
    if q_end is not None and len(coefficients) > 2:
        g = greville(times)
        bump = np.sin(np.pi * (g - times[0]) / (times[-1] - times[0]))  # (0 at both ends)
        weight = bump * (knots[3:] - knots[:-3]) / 3.0  # times int B_j
        corrected = coefficients + np.outer(bump, (q_end - positions[-1]) / weight.sum())
        # v is a convex combination of the coefficients, v' of their divided differences
        slope = 2.0 / (knots[3:-1] - knots[1:-3])[:, None]
        speed = np.abs(coefficients).max(axis=0)
        rate = np.abs(np.diff(coefficients, axis=0) * slope).max(axis=0)
        if limits is not None:  # (never below what the ticks used already)
            speed, rate = np.maximum(speed, limits[0]), np.maximum(rate, limits[1])
        keep = (np.abs(corrected).max(axis=0) <= speed) & (
            np.abs(np.diff(corrected, axis=0) * slope).max(axis=0) <= rate
        )
        if keep.any():
            coefficients[:, keep] = corrected[:, keep]
            spline = BSpline(knots, coefficients, 2, extrapolate=False)
            positions = spline.antiderivative()(times) + q0
            positions[-1, keep] = q_end[keep]  # (equal to rounding)
    return positions, spline(times), spline.derivative()(times)


def tick_velocity(
    rates: np.ndarray, dt: float, ticks: int, to_rest: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``(tau, w)`` of the controller's velocity: linear between them, ``tau`` [s] at whole
    ticks. The rate ``rates[k]`` (held over tick ``k``) is reached at ``tau = (k + 1) dt``, half a
    tick after the middle of its tick, by a ramp from the previous one (from rest at ``tau = 0``),
    so the displacement up to ``tau = j dt`` is the controller's up to ``(j - 1/2) dt`` exactly
    (and the whole run's, ``dt sum rates``, exactly): the controller's motion, half a tick late. ``ticks`` rates are used; ``to_rest`` adds a
    last ramp to rest (``tau = (ticks + 1) dt``).

    Args:
        rates: Rates of the ticks ``(>= ticks, dof)`` [rad/s].
        dt: Control period [s].
        ticks: Number of ticks run.
        to_rest: End at rest one tick after the last rate.
    """
    dof = rates.shape[1]
    rest = np.zeros((1, dof))
    values = [rest, rates[:ticks]] + ([rest] if to_rest else [])
    w = np.concatenate(values)
    return np.arange(len(w)) * dt, w
