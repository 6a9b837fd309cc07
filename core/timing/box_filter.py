"""A path timing s(t) with constant s'' between grid times, smoothed by a moving average.

``BoxFiltered(profile, width)`` is s_w(t) = (1/w) * integral of s over [t - w, t] (s = 0 before the
motion, its length after it): the same path from rest to rest, ``width`` [s] longer. Its
derivatives are differences of the profile's own one order lower: s_w' = (s(t) - s(t - w)) / w,
s_w'' = (s'(t) - s'(t - w)) / w, s_w''' = (s''(t) - s''(t - w)) / w. So a profile whose s'' jumps
(a time-optimal one: constant s'' between grid times) becomes one whose s'' is continuous and
s''' piecewise constant, |s_w'''| <= (largest s'' - smallest s'') / w: the finite-impulse-response
filtering by which CNC controllers make acceleration-limited feed profiles jerk-limited. s_w is a
monotone average of a monotone s, so the motion stays on the path; it is a piecewise cubic with
breaks at the grid times and at the grid times plus ``width`` (``breaks``).
"""

from __future__ import annotations

import numpy as np

from core.timing.path_profile import invert
from core.timing.speed_limited import GridTiming


class BoxFiltered:
    """``profile`` (s'' constant between its grid times, rest to rest) averaged over ``width``
    [s] > 0: s, s', s'', s''' at any time (``__call__``), over ``[0, duration]``."""

    def __init__(self, profile: GridTiming, width: float) -> None:
        self.profile = profile
        self.width = float(width)
        t, s, v, a = profile.t, profile.s, profile.sdot, profile.sddot
        dt = np.diff(t)
        # the integral of s from 0 to every grid time
        self._area = np.concatenate(
            [[0.0], np.cumsum(s[:-1] * dt + v[:-1] * dt**2 / 2 + a * dt**3 / 6)]
        )
        self.length = float(s[-1])
        self.duration = float(profile.duration) + self.width

    def breaks(self) -> np.ndarray:
        """Times [s] where s''' jumps: the profile's grid times and the same plus ``width``."""
        t = self.profile.t
        return np.unique(np.concatenate([t, t + self.width]))

    def switch_times(self) -> np.ndarray:
        """``breaks`` inside (0, duration) (a ``core.timing.path_profile.PathLaw``)."""
        b = self.breaks()
        return b[(b > 0.0) & (b < self.duration)]

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] where the motion reaches path parameters ``s`` (bisection)."""
        b = self.breaks()
        return invert(self, b, self(b), np.clip(np.asarray(s, dtype=float), 0.0, self.length))

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s (``order`` 0), s', s'' or s''' at times ``t`` [s] ``(K,)``."""
        t = np.asarray(t, dtype=float)
        if order == 0:
            return np.clip((self._integral(t) - self._integral(t - self.width)) / self.width,
                           0.0, self.length)  # fmt: skip
        return (self._raw(t, order - 1) - self._raw(t - self.width, order - 1)) / self.width

    def _raw(self, t: np.ndarray, order: int) -> np.ndarray:
        """The profile's s, s' or s'' at ``t``, at rest before and after it."""
        end = self.profile.duration
        inside = self.profile(np.clip(t, 0.0, end), order)
        if order == 0:
            return np.where(t <= 0.0, 0.0, np.where(t >= end, self.length, inside))
        return np.where((t <= 0.0) | (t >= end), 0.0, inside)

    def _integral(self, t: np.ndarray) -> np.ndarray:
        """The integral of s from 0 to ``t`` (s = 0 before 0, the length after the end)."""
        p = self.profile
        end = p.duration
        tc = np.clip(t, 0.0, end)
        i = np.clip(np.searchsorted(p.t, tc, side="right") - 1, 0, len(p.t) - 2)
        r = tc - p.t[i]
        value = self._area[i] + p.s[i] * r + p.sdot[i] * r**2 / 2 + p.sddot[i] * r**3 / 6
        after = self._area[-1] + self.length * (t - end)
        return np.where(t <= 0.0, 0.0, np.where(t >= end, after, value))
