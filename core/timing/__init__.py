"""Path timing laws s(t): the ``TIMING_LAWS`` registry (name -> law).

Every law has the same signature, ``law(spec: TimingSpec) -> Profile``: it reads what it needs from
the spec (a duration, or the path's extent and the tool speed limits, plus optional caps on s' and
s'' from the joints) and returns a rest-to-rest ``Profile`` s(t). Adding a law is one module plus
one line here. ``s_curve`` (``core.timing.s_curve``): continuous s'', |s'''| bounded by the tool
jerk limits (``max_linear_jerk`` [m/s^3], ``max_angular_jerk`` [rad/s^3]).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from core.errors import InputError
from core.timing.quintic import QuinticTiming
from core.timing.s_curve import SCurveTiming, s_curve_limited
from core.timing.speed_limited import (
    DEFAULT_ANGULAR_ACCELERATION,
    DEFAULT_LINEAR_ACCELERATION,
    GridTiming,
    speed_limited,
)


class Profile(Protocol):
    """s(t) on [0, duration] [s]: ``profile(t, order)`` gives s, s' [1/s], s'' [1/s^2];
    ``time_at(s)`` inverts it."""

    duration: float

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray: ...

    def time_at(self, s: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class TimingSpec:
    """What a timing law may use.

    Attributes:
        length: Distance [m] the tool travels along the path.
        angle: Rotation [rad] the tool turns through.
        duration: Fixed duration [s] (the ``quintic`` law), or None.
        max_linear_speed: Tool speed limit [m/s], or None.
        max_angular_speed: Tool angular speed limit [rad/s], or None.
        end: Path parameter reached at the end (a partial plan's fraction).
        s: Grid of path parameters ``(K,)`` the caps are given on, or None.
        cap: Further cap on s' [1/s] at each grid point ``(K,)`` (joint speeds), or None.
        acceleration_cap: Further bound on |s''| [1/s^2] per grid interval ``(K-1,)``, or None.
        max_linear_jerk: Tool jerk limit [m/s^3] (``s_curve``), or None for its default.
        max_angular_jerk: Tool angular jerk limit [rad/s^3] (``s_curve``), or None.
    """

    length: float = 0.0
    angle: float = 0.0
    duration: float | None = None
    max_linear_speed: float | None = None
    max_angular_speed: float | None = None
    end: float = 1.0
    s: np.ndarray | None = None
    cap: np.ndarray | None = None
    acceleration_cap: np.ndarray | None = None
    max_linear_jerk: float | None = None
    max_angular_jerk: float | None = None


TimingLaw = Callable[[TimingSpec], Profile]


def quintic(spec: TimingSpec) -> QuinticTiming:
    """The fixed-duration quintic (``core.timing.quintic``)."""
    if spec.duration is None:
        raise InputError("the quintic timing needs a duration", field=("duration",))
    return QuinticTiming(spec.duration, spec.end)


def speed_limited_law(spec: TimingSpec) -> GridTiming:
    """The shortest profile under the tool speed limits and the caps (``speed_limited``)."""
    return speed_limited(
        spec.length,
        spec.angle,
        spec.max_linear_speed,
        spec.max_angular_speed,
        cap=spec.cap,
        s=spec.s,
        acceleration_cap=spec.acceleration_cap,
    )


class EndScaled:
    """A rest-to-rest profile u(t) from 0 to 1 stretched to s(t) = end * u(t) (a partial plan's
    timing: s from 0 to ``end``)."""

    def __init__(self, profile: Profile, end: float) -> None:
        self.profile, self.end = profile, float(end)
        self.duration = float(profile.duration)

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        return self.end * np.asarray(self.profile(t, order), dtype=float)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        return self.profile.time_at(np.asarray(s, dtype=float) / self.end)


def s_curve_law(spec: TimingSpec) -> Profile:
    """The jerk-limited S-curve (``core.timing.s_curve``) from s = 0 to ``spec.end``.

    With ``duration``: exactly that long (the canonical S-curve; with a jerk limit given,
    ``Infeasible`` naming the shortest duration when it needs longer). Otherwise the shortest
    S-curve under the tool speed, acceleration (``DEFAULT_*_ACCELERATION``) and jerk limits, and
    under the smallest joint caps on s' and |s''| (an S-curve has one bound of each, so they hold
    conservatively).
    """
    end = float(spec.end)
    if spec.duration is not None:
        jerk = np.inf
        for extent, limit in (
            (spec.length, spec.max_linear_jerk),
            (spec.angle, spec.max_angular_jerk),
        ):
            if limit is not None and extent * end > 1e-12:
                jerk = min(jerk, limit / (extent * end))
        profile: Profile = SCurveTiming(
            spec.duration, max_jerk=float(jerk) if np.isfinite(jerk) else None
        )
    else:
        profile = s_curve_limited(
            spec.length * end,
            spec.angle * end,
            spec.max_linear_speed,
            spec.max_angular_speed,
            DEFAULT_LINEAR_ACCELERATION,
            DEFAULT_ANGULAR_ACCELERATION,
            spec.max_linear_jerk,
            spec.max_angular_jerk,
            cap=None if spec.cap is None else np.asarray(spec.cap) / end,
            acceleration_cap=(
                None if spec.acceleration_cap is None else np.asarray(spec.acceleration_cap) / end
            ),
        )
    return profile if end == 1.0 else EndScaled(profile, end)


TIMING_LAWS: dict[str, TimingLaw] = {
    "quintic": quintic,
    "speed_limited": speed_limited_law,
    "s_curve": s_curve_law,
}
