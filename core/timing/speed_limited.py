"""The speed-limited s(t): the shortest rest-to-rest profile under tool and joint limits.

The tool moves along a fixed geometric path parameterized by s in [0, 1]; timing only decides how fast
s advances, so re-timing never changes the path (the fixed-duration law is ``core.timing.quintic``).

- ``GridTiming``: the shortest time under a speed cap s'_max(s) and an acceleration bound s''_max,
  built by the classic forward/backward pass on the phase plane (s, s'^2): a trapezoid (or triangle)
  when the cap is constant, and a slow-down only where the cap is lower, e.g. where joint rates would
  exceed their limits. Acceleration is piecewise constant between grid points, so times are exact.
"""

from __future__ import annotations

import numpy as np

from core.errors import InputError

DEFAULT_LINEAR_ACCELERATION = 1.0
"""Tool acceleration [m/s^2] used with ``max_linear_speed`` when the request gives none."""
DEFAULT_ANGULAR_ACCELERATION = 2.0
"""Tool angular acceleration [rad/s^2] used with ``max_angular_speed`` when the request gives none."""
_GRID = 2001


class GridTiming:
    """Time-optimal s(t) under ``s' <= cap(s)`` and ``|s''| <= max_acceleration``, rest to rest.

    Args:
        s: Increasing grid of path parameters from 0 to 1 (to any end with ``from_speeds``),
            shape ``(K,)``.
        cap: Largest allowed s' [1/s] at each grid point, ``(K,)``, > 0 inside.
        max_acceleration: Bound on |s''| [1/s^2], > 0: one number, or one per interval ``(K-1,)``
            (for example from joint acceleration limits, which bound s'' less where joints move less).
    """

    def __init__(
        self, s: np.ndarray, cap: np.ndarray, max_acceleration: float | np.ndarray
    ) -> None:
        s = np.asarray(s, dtype=float)
        v2 = np.minimum(np.asarray(cap, dtype=float), 1e12) ** 2
        v2[0] = v2[-1] = 0.0
        acc = np.broadcast_to(np.asarray(max_acceleration, dtype=float), (len(s) - 1,))
        # A[i] = sum over intervals k < i of 2 a_k ds_k: the most v2 = s'^2 can grow from s[0].
        A = np.concatenate([[0.0], np.cumsum(2.0 * acc * np.diff(s))])
        # Forward pass: v2[i+1] <= v2[i] + 2 a_i ds_i, i.e. (v2 - A) non-increasing.
        v2 = np.minimum(v2, np.minimum.accumulate(v2 - A) + A)
        # Backward pass: v2[i] <= v2[i+1] + 2 a_i ds_i, i.e. (v2 + A) non-decreasing from the end.
        v2 = np.minimum(v2, np.minimum.accumulate((v2 + A)[::-1])[::-1] - A)
        self._set(s, np.sqrt(np.maximum(v2, 0.0)))

    @classmethod
    def from_speeds(cls, s: np.ndarray, sdot: np.ndarray) -> GridTiming:
        """The profile through path speeds ``sdot`` ``(K,)`` [1/s] (zero at both ends) at the grid
        ``s`` ``(K,)``, with constant s'' on every grid interval (a time-optimal law's answer)."""
        self = cls.__new__(cls)
        self._set(np.asarray(s, dtype=float), np.asarray(sdot, dtype=float))
        return self

    def _set(self, s: np.ndarray, sdot: np.ndarray) -> None:
        self.s = s
        self.sdot = sdot
        ds = np.diff(s)
        mean = self.sdot[:-1] + self.sdot[1:]
        dt = np.where(mean > 0, 2.0 * ds / np.where(mean > 0, mean, 1.0), np.inf)
        if not np.all(np.isfinite(dt)):
            raise InputError("the speed cap is zero inside the path; no timing exists")
        self.t = np.concatenate([[0.0], np.cumsum(dt)])
        self.sddot = (self.sdot[1:] - self.sdot[:-1]) / dt
        self.duration = float(self.t[-1])

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s, s' [1/s] or s'' [1/s^2] at times ``t`` [s] (piecewise constant acceleration)."""
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.duration)
        i = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2)
        tau = t - self.t[i]
        acc = self.sddot[i]
        if order == 0:
            return np.minimum(self.s[i] + self.sdot[i] * tau + 0.5 * acc * tau**2, self.s[-1])
        if order == 1:
            return np.maximum(self.sdot[i] + acc * tau, 0.0)
        return acc

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] at which the profile reaches path parameters ``s``."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.s[-1])
        i = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2)
        v0, acc, ds = self.sdot[i], self.sddot[i], s - self.s[i]
        # Solve ds = v0 tau + acc tau^2 / 2 for tau >= 0, stably.
        disc = np.sqrt(np.maximum(v0**2 + 2.0 * acc * ds, 0.0))
        denom = v0 + disc
        tau = np.where(denom > 0, 2.0 * ds / np.where(denom > 0, denom, 1.0), 0.0)
        return self.t[i] + tau

    def switch_times(self) -> np.ndarray:
        """Times [s] where s'' steps: every inner grid point."""
        return self.t[1:-1].copy()


def speed_limited(
    length: float,
    angle: float,
    max_linear_speed: float | None,
    max_angular_speed: float | None,
    max_linear_acceleration: float = DEFAULT_LINEAR_ACCELERATION,
    max_angular_acceleration: float = DEFAULT_ANGULAR_ACCELERATION,
    cap: np.ndarray | None = None,
    s: np.ndarray | None = None,
    acceleration_cap: np.ndarray | None = None,
) -> GridTiming:
    """Shortest rest-to-rest s(t) for a line of ``length`` [m] turning ``angle`` [rad].

    The tool's linear speed stays <= ``max_linear_speed`` [m/s] and angular speed <=
    ``max_angular_speed`` [rad/s] (each ignored when None or when the line has no such motion),
    accelerations likewise; ``cap`` (on grid ``s``) adds a further s' cap, e.g. from joint limits,
    and ``acceleration_cap`` (one per interval of ``s``, [1/s^2]) a further bound on |s''|.
    """
    sdot_max, sddot_max = np.inf, np.inf
    for extent, speed, acc in (
        (length, max_linear_speed, max_linear_acceleration),
        (angle, max_angular_speed, max_angular_acceleration),
    ):
        if extent > 1e-12:
            if speed is not None:
                sdot_max = min(sdot_max, speed / extent)
            sddot_max = min(sddot_max, acc / extent)
    if not np.isfinite(sdot_max) and cap is None:
        raise InputError(
            "give duration or max_linear_speed/max_angular_speed for a motion of this kind",
            field=("max_linear_speed",),
        )
    if not np.isfinite(sddot_max):
        sddot_max = 1.0
    grid = np.linspace(0.0, 1.0, _GRID) if s is None else np.asarray(s, dtype=float)
    full = np.full(grid.shape, sdot_max)
    if cap is not None:
        full = np.minimum(full, cap)
    if acceleration_cap is not None:
        return GridTiming(grid, full, np.minimum(sddot_max, acceleration_cap))
    return GridTiming(grid, full, sddot_max)
