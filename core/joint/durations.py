"""Durations from velocity and acceleration limits.

Joint-space part (point-to-point profiles and splines): the closed-form shortest durations of the
rest-to-rest profiles, and a numeric search for the shortest feasible duration (or time scale) when
no closed form exists. Limits themselves and the checks against them are in ``core.limits``.
Units: joint positions in [rad or m], velocities per [s], accelerations per [s^2].
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from core.errors import Infeasible
from core.timing.quintic import QUINTIC_PEAK_ACCELERATION, QUINTIC_PEAK_VELOCITY
from core.trajectory import MAX_DURATION

MIN_DURATION = 1e-3
"""Shortest trajectory the planners return [s]; a plan that needs less (no motion) is stretched."""
NONZERO_END_VELOCITY = (
    "the last point has non-zero velocity: a ROS 2 joint trajectory controller rejects it unless "
    "allow_nonzero_velocity_at_trajectory_end is true"
)
"""Warning attached to a plan that does not end at rest."""

CUBIC_PEAK_VELOCITY = 1.5
"""Rest-to-rest cubic: peak velocity is 1.5 |dq| / T."""
CUBIC_PEAK_ACCELERATION = 6.0
"""Rest-to-rest cubic: peak acceleration is 6 |dq| / T^2 (at both ends)."""

# --- Closed-form shortest durations, rest to rest (distance = |goal - start|, (dof,)) ---


def linear_duration(distance: np.ndarray, max_velocity: np.ndarray) -> float:
    """Constant velocity: ``max_j |dq_j| / vmax_j`` in [s] (acceleration is unbounded anyway)."""
    return float(np.max(distance / max_velocity))


def _polynomial_duration(
    distance: np.ndarray, max_velocity: np.ndarray, max_acc: np.ndarray, kv: float, ka: float
) -> float:
    """Rest to rest, peaks ``kv |dq| / T`` and ``ka |dq| / T^2``: ``max_j max(kv |dq|/vmax,
    sqrt(ka |dq|/amax))`` in [s]."""
    return float(np.max(np.maximum(kv * distance / max_velocity, np.sqrt(ka * distance / max_acc))))


def cubic_duration(distance: np.ndarray, max_velocity: np.ndarray, max_acc: np.ndarray) -> float:
    """Rest-to-rest cubic: ``max_j max(1.5 |dq|/vmax, sqrt(6 |dq|/amax))`` in [s]."""
    return _polynomial_duration(
        distance, max_velocity, max_acc, CUBIC_PEAK_VELOCITY, CUBIC_PEAK_ACCELERATION
    )


def quintic_duration(distance: np.ndarray, max_velocity: np.ndarray, max_acc: np.ndarray) -> float:
    """Rest-to-rest quintic: ``max_j max(1.875 |dq|/vmax, sqrt(5.7735 |dq|/amax))`` in [s]."""
    return _polynomial_duration(
        distance, max_velocity, max_acc, QUINTIC_PEAK_VELOCITY, QUINTIC_PEAK_ACCELERATION
    )


def trapezoidal_joint_durations(
    distance: np.ndarray, max_velocity: np.ndarray, max_acc: np.ndarray
) -> np.ndarray:
    """Time-optimal trapezoid (or triangle) per joint in [s], shape ``(dof,)``.

    A joint reaches its cruise speed ``vmax`` when ``|dq| >= vmax^2 / amax``: ``|dq|/vmax +
    vmax/amax``; otherwise the profile is a triangle: ``2 sqrt(|dq| / amax)``. ``amax`` must be
    finite.
    """
    with np.errstate(invalid="ignore"):  # inf/inf cannot occur: amax is finite
        cruise = distance >= max_velocity**2 / max_acc
        t_trap = distance / max_velocity + max_velocity / max_acc
    t_tri = 2.0 * np.sqrt(distance / max_acc)
    return np.where(cruise, t_trap, t_tri)


def trapezoidal_duration(
    distance: np.ndarray, max_velocity: np.ndarray, max_acc: np.ndarray
) -> float:
    """Synchronized trapezoid: the slowest joint's time-optimal duration in [s]."""
    return float(np.max(trapezoidal_joint_durations(distance, max_velocity, max_acc)))


# --- Numeric search ---

DIP_EXCESS = 0.5
"""A grid dip of ``excess`` above this cannot hide a feasible island within half a grid step (peaks
change by ~1/T to 1/T^2 across a 12 % step), so it is not refined."""


def shortest_feasible(
    excess: Callable[[np.ndarray], np.ndarray],
    lower: float = MIN_DURATION,
    upper: float = MAX_DURATION,
    grid_points: int = 161,
    dips: int = 3,
) -> float | None:
    """Smallest ``x`` in ``[lower, upper]`` with ``excess(x) <= 0``, or ``None`` when none is found.

    ``excess`` maps candidates ``(G,)`` to ``(G,)`` (for example the largest ratio of an exact peak
    to its limit, minus one). A geometric grid is scanned in one vectorized call. A feasible island
    narrower than a grid step shows as a dip of ``excess``: the ``dips`` lowest local minima under
    ``DIP_EXCESS`` before the first feasible grid point are minimized (bounded Brent) to find one.
    The left edge of the first feasible stretch is then refined by Brent's method and re-checked,
    so the answer is feasible.
    """
    grid = np.geomspace(lower, upper, grid_points)
    values = excess(grid)

    def scalar(x: float) -> float:
        return float(excess(np.array([x]))[0])

    feasible = np.flatnonzero(values <= 0.0)
    stop = int(feasible[0]) if feasible.size else grid.size
    if stop == 0:
        return float(grid[0])
    edges = [] if stop == grid.size else [(float(grid[stop - 1]), float(grid[stop]))]
    inner = np.arange(1, min(stop, grid.size - 1))
    local = inner[
        (values[inner] <= values[inner - 1])
        & (values[inner] <= values[inner + 1])
        & (values[inner] < DIP_EXCESS)
    ]
    for i in local[np.argsort(values[local])][:dips]:
        lo, hi = float(grid[i - 1]), float(grid[i + 1])
        found = minimize_scalar(
            scalar, bounds=(lo, hi), method="bounded", options={"xatol": 1e-9 * lo}
        )
        if found.fun <= 0.0:
            edges.append((lo, float(found.x)))
    best = None
    for lo, hi in edges:
        x = _left_edge(scalar, lo, hi)
        best = x if best is None else min(best, x)
    return best


def _left_edge(scalar: Callable[[float], float], lo: float, hi: float) -> float:
    """A feasible ``x`` at the sign change in ``[lo, hi]`` (``scalar(lo) > 0 >= scalar(hi)``)."""
    x = float(brentq(scalar, lo, hi, xtol=1e-13 * hi, rtol=1e-15))
    for _ in range(8):
        if scalar(x) <= 0.0:
            return x
        x *= 1.0 + 1e-12
    return hi


def clamp_duration(duration: float, what: str) -> float:
    """``duration`` raised to ``MIN_DURATION``; ``Infeasible`` over ``MAX_DURATION``/not finite."""
    if not np.isfinite(duration) or duration > MAX_DURATION:
        raise Infeasible(
            f"{what} needs more than {MAX_DURATION:g} s under these limits", field=("limits",)
        )
    return max(float(duration), MIN_DURATION)
