"""The Trajectory value type and the sampling of time.

A trajectory is the answer of every planner: sample times ``(N,)`` in [s], strictly increasing from
0.0 to the duration, and positions, velocities, accelerations ``(N, dof)`` in joint units (rad or m,
per second, per second squared).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np

from core.errors import Infeasible, InputError, TooLarge

MAX_POINTS = 100_000
"""Most points one trajectory (one response) may hold."""

MAX_DURATION = 1e5
"""Longest trajectory any planner returns [s] (about 28 h): the API's bound on every duration, given
or planned. Its times stay exact to well below a nanosecond in float64 and fit a ROS Duration's
int32 seconds and any int64 count of nanoseconds."""

DEFAULT_SAMPLE_PERIOD = 0.01
"""Sample period in [s] used when a request gives neither ``sample_period`` nor ``samples``."""

SAMPLING_ADMISSION: ContextVar[Callable[[int], None] | None] = ContextVar(
    "sampling_admission", default=None
)
"""Called by ``sample_times`` with the point count before a grid is allocated, in the caller's
context: a service admits the memory the samples will take (raising its own exception to refuse
them) before the planner fills arrays of that length. None: no admission."""


class Peaks(NamedTuple):
    """Largest |velocity|, |acceleration| and |jerk| of each joint over the whole profile (not
    only at the samples), each ``(dof,)`` in [rad or m] per [s], [s^2], [s^3]."""

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray


class Profile(Protocol):
    """Anything built once and sampled many times: ``profile(t, order)`` -> ``(len(t), dof)``,
    with its exact ``peaks()`` over ``[0, duration]``."""

    duration: float

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray: ...

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def peaks(self) -> Peaks: ...

    def switch_times(self) -> np.ndarray:
        """Times [s] inside (0, duration) where a derivative up to the jerk may step (between
        two of them the profile is smooth)."""
        ...


@dataclass(frozen=True)
class Trajectory:
    """A timed joint trajectory.

    Attributes:
        times: Sample times in [s], shape ``(N,)``, strictly increasing, ``times[0] == 0``.
        positions: Joint positions, shape ``(N, dof)``.
        velocities: Joint velocities, shape ``(N, dof)``.
        accelerations: Joint accelerations, shape ``(N, dof)``.
        joint_names: One name per joint.
        peaks: Exact peaks of the profile the samples come from (``None``: not known, and the
            ``peak_*`` properties read the samples).
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    joint_names: tuple[str, ...] = field(default=())
    peaks: Peaks | None = None

    def __post_init__(self) -> None:
        n, dof = self.positions.shape
        if self.times.shape != (n,):
            raise ValueError(f"times has shape {self.times.shape}, expected ({n},)")
        for name in ("velocities", "accelerations"):
            if getattr(self, name).shape != (n, dof):
                raise ValueError(
                    f"{name} has shape {getattr(self, name).shape}, expected {(n, dof)}"
                )
        if not self.joint_names:
            object.__setattr__(self, "joint_names", default_joint_names(dof))
        elif len(self.joint_names) != dof:
            raise ValueError(f"{len(self.joint_names)} joint names for {dof} joints")

    @property
    def dof(self) -> int:
        return int(self.positions.shape[1])

    @property
    def duration(self) -> float:
        """Time of the last point in [s]."""
        return float(self.times[-1])

    @property
    def peak_velocity(self) -> np.ndarray:
        """Largest |velocity| of each joint ``(dof,)``: exact when ``peaks`` is known, else over
        the samples."""
        if self.peaks is not None:
            return self.peaks.velocity
        return np.abs(self.velocities).max(axis=0)

    @property
    def peak_acceleration(self) -> np.ndarray:
        """Largest |acceleration| of each joint ``(dof,)``: exact when ``peaks`` is known, else
        over the samples."""
        if self.peaks is not None:
            return self.peaks.acceleration
        return np.abs(self.accelerations).max(axis=0)

    @property
    def peak_jerk(self) -> np.ndarray:
        """Largest |jerk| of each joint ``(dof,)``: exact when ``peaks`` is known, else the
        largest slope of the sampled accelerations between consecutive points
        (``sampled_peak_jerk``)."""
        if self.peaks is not None:
            return self.peaks.jerk
        return sampled_peak_jerk(self.times, self.accelerations)

    @classmethod
    def from_profile(
        cls, profile: Profile, times: np.ndarray, joint_names: tuple[str, ...] = ()
    ) -> Trajectory:
        """Sample ``profile`` (positions, velocities, accelerations, the three orders at once) at
        ``times``; the trajectory carries the profile's exact ``peaks()``."""
        q, qd, qdd = profile.sample(times)
        return cls(
            times=times,
            positions=q,
            velocities=qd,
            accelerations=qdd,
            joint_names=tuple(joint_names),
            peaks=profile.peaks(),
        )


def sampled_peak_jerk(times: np.ndarray, accelerations: np.ndarray) -> np.ndarray:
    """Largest |slope| of ``accelerations`` ``(N, dof)`` between consecutive ``times`` ``(N,)``
    [s], ``(dof,)``: a lower bound of the true peak jerk, for trajectories whose profile is not
    known in closed form (zeros for a single point)."""
    if times.size < 2:
        return np.zeros(accelerations.shape[1])
    slopes = np.abs(np.diff(accelerations, axis=0)) / np.diff(times)[:, None]
    return slopes.max(axis=0)


@functools.lru_cache(maxsize=64)
def default_joint_names(dof: int) -> tuple[str, ...]:
    """``("j1", ..., "jn")``: the names used when a request names no robot."""
    return tuple(f"j{i + 1}" for i in range(dof))


def check_duration(duration: float) -> None:
    """``Infeasible`` (``extra``: ``duration``, ``max_duration`` [s]) unless ``0 <= duration <=
    MAX_DURATION``: the one bound of every returned plan, whatever made it long (tiny limits,
    scales or speeds)."""
    if not 0.0 <= duration <= MAX_DURATION:
        raise Infeasible(
            f"the plan would last {duration:.4g} s, over the limit of {MAX_DURATION:g} s of every "
            "trajectory (raise the limits, scales or speeds that slow it down)",
            extra={"duration": float(duration), "max_duration": MAX_DURATION},
        )


MIN_LAST_INTERVAL = 1e-6
"""Shortest last interval [s] of a ``sample_period`` grid: a shorter one (a duration a hair past a
multiple of the period) is merged into the interval before it, so no pair of returned points is
closer than a microsecond (finite-difference accelerations over such a pair are meaningless: a
resolved-rate plan ending 1.6e-7 s after its last grid point reported 7.8e3 rad/s^2)."""


def _admit(points: int) -> None:
    admit = SAMPLING_ADMISSION.get()
    if admit is not None:
        admit(points)


def sample_times(
    duration: float,
    sample_period: float | None = None,
    samples: int | None = None,
    max_points: int = MAX_POINTS,
) -> np.ndarray:
    """Sample times in [s] from 0 to ``duration`` inclusive, strictly increasing.

    Args:
        duration: Trajectory length in [s], > 0; over ``MAX_DURATION`` is ``Infeasible``.
        sample_period: Spacing in [s]; the last interval may be shorter so the last point is at
            ``duration`` (one shorter than ``MIN_LAST_INTERVAL`` is merged into its neighbour).
        samples: Number of points (>= 2), evenly spaced; overrides ``sample_period``.
        max_points: Upper bound on the count; more is ``TooLarge`` (checked before allocating).
            The count is then passed to the ``SAMPLING_ADMISSION`` hook, if one is set.

    Returns:
        Times, shape ``(N,)``, ``N >= 2``.
    """
    if not np.isfinite(duration) or duration <= 0.0:
        raise InputError("duration must be a finite number > 0 s", field=("duration",))
    check_duration(duration)
    if samples is not None:
        if samples < 2:
            raise InputError("samples must be at least 2", field=("samples",))
        if samples > max_points:
            raise TooLarge(
                f"samples={samples} exceeds the limit of {max_points} points", field=("samples",)
            )
        _admit(int(samples))
        # np.linspace(0, duration, samples) without its overhead: the same products i * step.
        times = np.arange(int(samples), dtype=float) * (duration / (int(samples) - 1))
        times[-1] = duration
        return times
    period = DEFAULT_SAMPLE_PERIOD if sample_period is None else float(sample_period)
    if not np.isfinite(period) or period <= 0.0:
        raise InputError("sample_period must be a finite number > 0 s", field=("sample_period",))
    # Count in floats first: a subnormal period (5e-324) makes the ratio inf, which int() refuses.
    points = float(np.ceil(duration / period - 1e-9)) + 1.0
    if not points <= max_points:
        # .4g: a period of 1e-155 s gives 1e160 points, not a 160-digit integer in the detail
        count = f"{points:.4g}" if np.isfinite(points) else f"more than {max_points}"
        raise TooLarge(
            f"duration {duration:.6g} s at sample_period {period:.6g} s gives {count} "
            f"points, over the limit of {max_points}",
            field=("sample_period",),
        )
    intervals = int(points) - 1
    _admit(intervals + 1)
    times = np.arange(intervals + 1, dtype=float) * period
    times[-1] = duration
    if intervals >= 2 and times[-1] - times[-2] < MIN_LAST_INTERVAL:
        times = np.delete(times, -2)
    return times
