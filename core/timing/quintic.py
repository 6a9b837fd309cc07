"""The one quintic rest-to-rest s(t): a fixed duration.

s(t) = end * (10u^3 - 15u^4 + 6u^5), u = t / duration: zero speed and acceleration at both ends,
peak s' = 1.875 end / duration. Its inverse (``time_at``) is exact to 2^-60 of the duration, by
bisection on the monotone polynomial.
"""

from __future__ import annotations

import numpy as np

from core.errors import InputError

QUINTIC_PEAK_VELOCITY = 15.0 / 8.0
"""Rest-to-rest quintic: peak velocity 1.875 |dq| / T (peak s' is 1.875 / duration)."""
QUINTIC_PEAK_ACCELERATION = 10.0 / np.sqrt(3.0)
"""Rest-to-rest quintic: peak acceleration 5.7735 |dq| / T^2."""
_BISECTIONS = 60


class QuinticTiming:
    """s(t) for a fixed ``duration`` [s], from s = 0 to ``end``, quintic and rest to rest."""

    def __init__(self, duration: float, end: float = 1.0) -> None:
        if not np.isfinite(duration) or duration <= 0:
            raise InputError("duration must be > 0 s", field=("duration",))
        self.duration = float(duration)
        self.end = float(end)

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s (order 0), s' [1/s] (1) or s'' [1/s^2] (2) at times ``t`` [s]."""
        T = self.duration
        u = np.clip(np.asarray(t, dtype=float) / T, 0.0, 1.0)
        if order == 0:
            return self.end * (u**3 * (10.0 - 15.0 * u + 6.0 * u**2))
        if order == 1:
            return self.end * (30.0 * u**2 * (1.0 - u) ** 2 / T)
        return self.end * (60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / T**2)

    def phase(self, s: np.ndarray) -> np.ndarray:
        """u in [0, 1] where the profile reaches ``s`` (exact inverse, by bisection)."""
        target = np.clip(np.asarray(s, dtype=float) / self.end, 0.0, 1.0)
        lo, hi = np.zeros_like(target), np.ones_like(target)
        for _ in range(_BISECTIONS):
            mid = 0.5 * (lo + hi)
            below = mid**3 * (10.0 - 15.0 * mid + 6.0 * mid**2) < target
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return 0.5 * (lo + hi)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] at which the profile reaches path parameters ``s``."""
        return self.phase(s) * self.duration

    def switch_times(self) -> np.ndarray:
        """None: a polynomial is smooth inside (0, duration)."""
        return np.zeros(0)
