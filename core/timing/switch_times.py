"""Returned times that hold every switch of a timed motion, so that returned velocities and
accelerations are the exact derivatives of the returned motion.

A time-optimal path law has s'' constant between its switch times (``TimeOptimal.switch_times``):
joint accelerations jump there. ``with_switches`` merges the requested sampling
(``core.trajectory.sample_times``) with a pair of times ``MIN_SPACING`` apart around every interior
switch (the switch exactly between them, so integrating the returned accelerations over the pair by
the trapezoid rule integrates the jump exactly, and no other pair of consecutive points holds one),
or the switch times themselves when the pairs would exceed ``max_points`` or when the acceleration
is continuous there (``pairs=False``: a jerk-limited S-curve, whose acceleration is linear between
its switch times, so the trapezoid rule is exact between consecutive points). Any other two times
closer than ``MIN_SPACING`` are one (``jumps``: the grid times where s'' does change). Used by
``core.joint.retime``, ``core.motion.sample`` and ``core.cartesian.timing``.
Units: [s].
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from core.errors import TooLarge
from core.trajectory import sample_times

MIN_SPACING = 1e-6
"""Returned points closer than this [s] are one (a switch time wins over a sample time)."""
JUMP = 1e-9
"""A grid time where s'' changes by at most this, relative to its largest magnitude, is no switch
(a straight segment's cruise, where rounding makes s'' differ in its last digits)."""


class PathLaw(Protocol):
    """s(t) with s'' constant between ``switch_times`` (``core.timing.topp.TimeOptimal``)."""

    switch_times: np.ndarray

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray: ...


def jumps(law: PathLaw) -> np.ndarray:
    """The switch times of ``law`` where s'' jumps (more than ``JUMP``), 0 and the duration
    kept: the times ``with_switches`` must hold (where only s''' changes is no jump)."""
    return jumps_at(law, law.switch_times)


def jumps_at(law: Callable[[np.ndarray, int], np.ndarray], switch_times: np.ndarray) -> np.ndarray:
    """``jumps`` of an s(t) ``law`` whose switch times are ``switch_times`` ``(M,)`` (0 and the
    duration first and last; a ``core.timing.PathLaw`` gives its inner ones by a method)."""
    t = np.asarray(switch_times, dtype=float)
    if len(t) < 3:
        return t
    # s'' at each interval's ends, from two points inside it (exact for s'' constant, as TOPP's,
    # or linear, as a jerk-limited S-curve's, whose continuous s'' is then no jump)
    width = np.diff(t)
    a, b = t[:-1] + width / 3.0, t[:-1] + 2.0 * width / 3.0
    ua = np.asarray(law(a, 2), dtype=float)
    ub = np.asarray(law(b, 2), dtype=float)
    change = ub - ua  # s'' over the middle third: a third of its change over the interval
    right, left = ua - change, ub + change  # s'' at the start and at the end of each interval
    scale = max(float(np.abs(ua).max()), float(np.abs(ub).max()), 1e-300)
    jump = np.abs(right[1:] - left[:-1]) > JUMP * scale
    return np.concatenate([t[:1], t[1:-1][jump], t[-1:]])


def with_switches(
    switch_times: np.ndarray,
    sample_period: float | None,
    samples: int | None,
    max_points: int,
    *,
    pairs: bool = True,
) -> np.ndarray:
    """The sample times of a motion whose switch times are ``switch_times`` ``(M,)`` (0 and the
    duration first and last) with every interior switch held as the module docstring says;
    ``TooLarge`` at the sampling field when they exceed ``max_points``."""
    switch_times = np.asarray(switch_times, dtype=float)
    duration = float(switch_times[-1])
    base = sample_times(duration, sample_period, samples, max_points)
    switch = switch_times[1:-1]
    half = 0.5 * MIN_SPACING
    wide = np.diff(switch_times)
    alone = (wide[:-1] > 4.0 * MIN_SPACING) & (wide[1:] > 4.0 * MIN_SPACING) & pairs
    if len(base) + len(switch) + alone.sum() > max_points:
        alone[:] = False  # no room for pairs: one point at each switch (a path of many pieces)
    held = np.concatenate([switch[alone] - half, switch[alone] + half, switch[~alone]])
    fixed = np.concatenate([[0.0, duration], held])
    fixed.sort()
    near = np.searchsorted(fixed, base)
    gap = np.minimum(
        np.abs(base - fixed[np.clip(near, 0, len(fixed) - 1)]),
        np.abs(base - fixed[np.clip(near - 1, 0, len(fixed) - 1)]),
    )
    merged = np.union1d(fixed, base[gap >= MIN_SPACING])
    keep = np.concatenate([[True], np.diff(merged) >= 0.99 * MIN_SPACING])
    merged = merged[keep]
    merged[-1] = duration
    if len(merged) > max_points:
        raise TooLarge(
            f"the motion switches acceleration at {len(switch)} times; with the sampling asked "
            f"that is {len(merged)} points, over the limit of {max_points}",
            field=("samples",) if samples is not None else ("sample_period",),
        )
    return merged
