"""Path timing laws s(t): the ``TIMING_LAWS`` registry (name -> law).

The names are the request's names (a Cartesian request's and a LIN/CIRC segment's
``speed_profile``): the schema's ``Literal`` is built from this dict, and every timing goes through
it (no code branches on a law's name). Every law has the same signature,
``law(spec: TimingSpec) -> PathLaw``: it reads what it needs from the spec and returns a
rest-to-rest s(t) (``core.timing.path_profile.PathLaw``):

- a Cartesian path (``spec.path`` None): a duration, or the path's extent and the tool limits,
  plus optional caps on s' and s'' from the joints (``core.cartesian.timing``);
- a joint path (``spec.path``, a ``JointPath``, with ``spec.limits``, ``PathLimits``): a motion
  program's rest-to-rest stretch (``core.program.chunks``) or any other geometric joint path.

``trapezoidal``: the quintic over a fixed duration; else the speed-limited phase-plane trapezoid
(``core.timing.speed_limited``); on a joint path, that trapezoid smoothed to C4 within the joint and
tool limits (``core.timing.path_trapezoid``). ``s_curve``: continuous s'', |s'''| bounded by the
tool jerk limits (``max_linear_jerk`` [m/s^3], ``max_angular_jerk`` [rad/s^3];
``core.timing.s_curve``, on a joint path ``core.timing.path_s_curve``).

Two laws time joint paths only (``JOINT_PATH_LAWS``: a motion program's ``timing``; a Cartesian
``speed_profile`` takes the other keys): ``time_optimal`` (``core.timing.optimal_law``: TOPP-RA's
reachability analysis, every joint, tool and effort limit kept at every instant; a program's
default, ``PROGRAM_DEFAULT``) and ``jerk_limited`` (the smoothed trapezoid of ``trapezoidal`` on a
joint path: acceleration continuous, the program timing of round 2). Adding a law is one module
plus one line here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.errors import InputError
from core.timing.joint_path import JointPath
from core.timing.optimal_law import optimal
from core.timing.path_limits import PathLimits
from core.timing.path_profile import PathLaw
from core.timing.path_s_curve import shaped_s_curve
from core.timing.path_trapezoid import smooth_trapezoid
from core.timing.quintic import QuinticTiming
from core.timing.s_curve import SCurveTiming, s_curve_limited
from core.timing.speed_limited import (
    DEFAULT_ANGULAR_ACCELERATION,
    DEFAULT_LINEAR_ACCELERATION,
    speed_limited,
)

__all__ = [
    "DEFAULT_LAW",
    "JOINT_PATH_LAWS",
    "PROGRAM_DEFAULT",
    "TIMING_LAWS",
    "EndScaled",
    "PathLaw",
    "TimingLaw",
    "TimingSpec",
]


@dataclass(frozen=True)
class TimingSpec:
    """What a timing law may use.

    Attributes:
        length: Distance [m] the tool travels along the path.
        angle: Rotation [rad] the tool turns through.
        duration: Fixed duration [s], or None.
        max_linear_speed: Tool speed limit [m/s], or None.
        max_angular_speed: Tool angular speed limit [rad/s], or None.
        end: Path parameter reached at the end (a partial plan's fraction).
        s: Grid of path parameters ``(K,)`` the caps are given on, or None.
        cap: Further cap on s' [1/s] at each grid point ``(K,)`` (joint speeds), or None.
        acceleration_cap: Further bound on |s''| [1/s^2] per grid interval ``(K-1,)``, or None.
        max_linear_jerk: Tool jerk limit [m/s^3] (``s_curve``), or None for its default.
        max_angular_jerk: Tool angular jerk limit [rad/s^3] (``s_curve``), or None.
        max_linear_acceleration: Tool acceleration limit [m/s^2] (None: 1 m/s^2).
        max_angular_acceleration: Tool angular acceleration limit [rad/s^2] (None: 2 rad/s^2).
        path: A geometric joint path to time (a program's stretch between stops), or None.
        limits: The limits along ``path`` (needed with it).
        joint_names: Names of the path's joints (errors name them), or () for j1..jn.
        deadline: Wall-time budget of the timing.
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
    max_linear_acceleration: float | None = None
    max_angular_acceleration: float | None = None
    path: JointPath | None = None
    limits: PathLimits | None = None
    joint_names: tuple[str, ...] = ()
    deadline: Deadline = NO_DEADLINE

    def accelerations(self) -> tuple[float, float]:
        """Tool acceleration limits [m/s^2], [rad/s^2] (the defaults where not given)."""
        lin, ang = self.max_linear_acceleration, self.max_angular_acceleration
        return (
            DEFAULT_LINEAR_ACCELERATION if lin is None else float(lin),
            DEFAULT_ANGULAR_ACCELERATION if ang is None else float(ang),
        )

    def joint_path(self) -> tuple[JointPath, PathLimits]:
        """``(path, limits)`` of a joint-path timing (``InputError`` when the limits are missing)."""
        if self.path is None or self.limits is None:
            raise InputError("a joint path is timed under its limits: give both")
        return self.path, self.limits


TimingLaw = Callable[[TimingSpec], PathLaw]


class EndScaled:
    """A rest-to-rest profile u(t) from 0 to 1 stretched to s(t) = end * u(t) (a partial plan's
    timing: s from 0 to ``end``)."""

    def __init__(self, profile: PathLaw, end: float) -> None:
        self.profile, self.end = profile, float(end)
        self.duration = float(profile.duration)

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        return self.end * np.asarray(self.profile(t, order), dtype=float)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        return self.profile.time_at(np.asarray(s, dtype=float) / self.end)

    def switch_times(self) -> np.ndarray:
        return self.profile.switch_times()


def trapezoidal(spec: TimingSpec) -> PathLaw:
    """The quintic over ``duration``; else the shortest speed-limited s(t) under the tool limits and
    the caps; on a joint path, the smoothed trapezoid (see the module docstring)."""
    if spec.path is not None:
        return smooth_trapezoid(*spec.joint_path())
    if spec.duration is not None:
        return QuinticTiming(spec.duration, spec.end)
    linear, angular = spec.accelerations()
    return speed_limited(
        spec.length,
        spec.angle,
        spec.max_linear_speed,
        spec.max_angular_speed,
        linear,
        angular,
        cap=spec.cap,
        s=spec.s,
        acceleration_cap=spec.acceleration_cap,
    )


def s_curve(spec: TimingSpec) -> PathLaw:
    """The jerk-limited S-curve (``core.timing.s_curve``) from s = 0 to ``spec.end``.

    With ``duration``: exactly that long (the canonical S-curve; with a jerk limit given,
    ``Infeasible`` naming the shortest duration when it needs longer). Otherwise the shortest
    S-curve under the tool speed, acceleration and jerk limits, and under the smallest joint caps
    on s' and |s''| (an S-curve has one bound of each, so they hold conservatively). On a joint
    path: ``core.timing.path_s_curve``.
    """
    if spec.path is not None:
        return shaped_s_curve(*spec.joint_path())
    end = float(spec.end)
    profile: PathLaw
    if spec.duration is not None:
        jerk = np.inf
        for extent, limit in (
            (spec.length, spec.max_linear_jerk),
            (spec.angle, spec.max_angular_jerk),
        ):
            if limit is not None and extent * end > 1e-12:
                jerk = min(jerk, limit / (extent * end))
        profile = SCurveTiming(spec.duration, max_jerk=float(jerk) if np.isfinite(jerk) else None)
    else:
        linear, angular = spec.accelerations()
        profile = s_curve_limited(
            spec.length * end,
            spec.angle * end,
            spec.max_linear_speed,
            spec.max_angular_speed,
            linear,
            angular,
            spec.max_linear_jerk,
            spec.max_angular_jerk,
            cap=None if spec.cap is None else np.asarray(spec.cap) / end,
            acceleration_cap=(
                None if spec.acceleration_cap is None else np.asarray(spec.acceleration_cap) / end
            ),
        )
    return profile if end == 1.0 else EndScaled(profile, end)


def _joint_path_only(name: str, spec: TimingSpec) -> tuple[JointPath, PathLimits]:
    if spec.path is None:
        raise InputError(
            f"{name} times a joint path (a program's timing), not a Cartesian speed_profile",
            field=("speed_profile",),
        )
    return spec.joint_path()


def time_optimal(spec: TimingSpec) -> PathLaw:
    """The time-optimal law of a joint path (``core.timing.optimal_law``) under
    ``spec.limits.rows``."""
    path, limits = _joint_path_only("time_optimal", spec)
    return optimal(path, limits.rows, spec.joint_names, spec.deadline)


def jerk_limited(spec: TimingSpec) -> PathLaw:
    """A joint path's smoothed trapezoid (C4: continuous acceleration; ``trapezoidal``'s)."""
    return smooth_trapezoid(*_joint_path_only("jerk_limited", spec))


TIMING_LAWS: dict[str, TimingLaw] = {
    "trapezoidal": trapezoidal,
    "s_curve": s_curve,
    "time_optimal": time_optimal,
    "jerk_limited": jerk_limited,
}
DEFAULT_LAW = "trapezoidal"
"""The law of a request that names none (a Cartesian request's and a segment's ``speed_profile``
default; on a LIN/CIRC segment it means "the program's timing")."""
JOINT_PATH_LAWS = frozenset({"time_optimal", "jerk_limited"})
"""Laws that time a joint path only: a program's ``timing`` takes them, a ``speed_profile`` the
other keys."""
PROGRAM_DEFAULT = "time_optimal"
"""The timing of a program's stretches between stops when the program names none."""


def speed_profile_law(name: str) -> bool:
    """Whether ``name`` may be a ``speed_profile``: a key of ``TIMING_LAWS`` that times a
    Cartesian path (not in ``JOINT_PATH_LAWS``)."""
    return name in TIMING_LAWS and name not in JOINT_PATH_LAWS


def program_law(name: str) -> bool:
    """Whether ``name`` may be a program's ``timing`` (a key in ``JOINT_PATH_LAWS``)."""
    return name in TIMING_LAWS and name in JOINT_PATH_LAWS
