"""Path timing laws s(t): the ``TIMING_LAWS`` registry (name -> law).

Every law has the same signature, ``law(spec: TimingSpec) -> Profile``: it reads what it needs from
the spec (a duration, or the path's extent and the tool speed limits, plus optional caps on s' and
s'' from the joints) and returns a rest-to-rest ``Profile`` s(t). Adding a law (e.g. the joint
team's jerk-limited ``s_curve``) is one module plus one line here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from core.errors import InputError
from core.timing.quintic import QuinticTiming
from core.timing.speed_limited import GridTiming, speed_limited


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


TIMING_LAWS: dict[str, TimingLaw] = {
    "quintic": quintic,
    "speed_limited": speed_limited_law,
}
