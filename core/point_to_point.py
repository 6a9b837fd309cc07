"""Planning a point-to-point joint move: the input, the choice of duration, the checks, sampling.

``plan_joint`` is the one core call of ``POST /v1/trajectories/joint``: it validates the move
against the profile and the limits, picks the shortest duration within the velocity/acceleration
limits when none is given (``core.timing``), builds the profile (``core.polynomials``), samples it,
and verifies the samples against the limits. Units: [rad or m], [s]; arrays ``(dof,)`` or
``(N, dof)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from core import timing
from core.errors import InputError, JointRateLimit
from core.limits import (
    JointLimits,
    check_boundary_rates,
    check_positions,
    check_rates,
    joint_vector,
)
from core.polynomials import LinearProfile, PolynomialProfile, TrapezoidalProfile
from core.trajectory import MAX_POINTS, Trajectory, default_joint_names, sample_times

PROFILES = ("linear", "cubic", "quintic", "trapezoidal")


class State(NamedTuple):
    """Boundary conditions at one end, each ``(dof,)``: [rad or m], per [s], per [s^2]."""

    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


BOUNDARY_RATES = {
    "linear": (),
    "trapezoidal": (),
    "cubic": ("velocities",),
    "quintic": ("velocities", "accelerations"),
}
"""Which non-zero boundary rates each profile honours (the others must be zero)."""


@dataclass(frozen=True)
class PointToPoint:
    """A joint-space move from ``start`` to ``goal`` (field names as in the API)."""

    start: State
    goal: State

    @classmethod
    def create(
        cls,
        start_positions: object,
        goal_positions: object,
        start_velocities: object = None,
        goal_velocities: object = None,
        start_accelerations: object = None,
        goal_accelerations: object = None,
    ) -> PointToPoint:
        """Validated move; missing rates are zero. ``InputError`` names the field at fault."""
        dof = int(np.size(start_positions))
        if np.ndim(start_positions) != 1 or dof == 0:
            raise InputError(
                "start.positions needs one value per joint", field=("start", "positions")
            )

        def state(end: str, q: object, v: object, a: object) -> State:
            return State(
                joint_vector(q, dof, (end, "positions")),
                joint_vector(v, dof, (end, "velocities"), default=0.0),
                joint_vector(a, dof, (end, "accelerations"), default=0.0),
            )

        return cls(
            state("start", start_positions, start_velocities, start_accelerations),
            state("goal", goal_positions, goal_velocities, goal_accelerations),
        )

    @property
    def dof(self) -> int:
        return int(self.start.positions.size)

    @property
    def distance(self) -> np.ndarray:
        """``|goal - start|`` per joint, ``(dof,)``."""
        return np.abs(self.goal.positions - self.start.positions)

    @property
    def at_rest(self) -> bool:
        """True when every boundary velocity and acceleration is zero."""
        return not any(
            np.any(x.velocities) or np.any(x.accelerations) for x in (self.start, self.goal)
        )


class JointPlan(NamedTuple):
    """A planned move: the sampled ``trajectory``, the ``profile`` (sample it anywhere in
    ``[0, T]``) and human-readable ``warnings``."""

    trajectory: Trajectory
    profile: PolynomialProfile | LinearProfile | TrapezoidalProfile
    warnings: tuple[str, ...]


def build_profile(
    kind: str, motion: PointToPoint, duration: float | np.ndarray, max_acceleration: np.ndarray
) -> PolynomialProfile | LinearProfile | TrapezoidalProfile:
    """The ``kind`` profile of ``motion`` lasting ``duration`` [s] (trapezoid ramps: the limits)."""
    start, goal = motion.start, motion.goal
    if kind == "linear":
        return LinearProfile(start.positions, goal.positions, float(duration))
    if kind == "trapezoidal":
        return TrapezoidalProfile(
            start.positions, goal.positions, float(duration), max_acceleration
        )
    quintic = kind == "quintic"
    return PolynomialProfile(
        start.positions,
        goal.positions,
        duration,
        start.velocities,
        goal.velocities,
        start.accelerations if quintic else None,
        goal.accelerations if quintic else None,
    )


def shortest_duration(kind: str, motion: PointToPoint, limits: JointLimits) -> float:
    """Shortest ``T`` [s] keeping every joint within ``limits`` (before the ``MIN_DURATION`` floor).

    Closed form for linear, trapezoidal and rest-to-rest cubic/quintic; otherwise a vectorized scan
    of exact peaks over candidate durations, refined by Brent's method (``shortest_feasible``).
    Raises ``InputError`` naming ``limits`` when the needed limits are missing, ``JointRateLimit``
    when no duration up to ``MAX_DURATION`` fits.
    """
    dist, vmax, amax = motion.distance, *limits.maxima(motion.dof)
    needed = {"linear": "velocity", "trapezoidal": "acceleration"}.get(kind)
    if needed and getattr(limits, needed) is None:
        raise InputError(
            f"the {kind} profile needs limits.{needed} or a duration", field=("limits", needed)
        )
    if limits.velocity is None and limits.acceleration is None:
        raise InputError(
            "give a duration, or limits (or a robot) to time the move", field=("limits",)
        )
    if kind == "linear":
        return timing.linear_duration(dist, vmax)
    if kind == "trapezoidal":
        return timing.trapezoidal_duration(dist, vmax, amax)
    if motion.at_rest:
        closed = timing.quintic_duration if kind == "quintic" else timing.cubic_duration
        return closed(dist, vmax, amax)

    def excess(durations: np.ndarray) -> np.ndarray:
        vel, acc = build_profile(kind, motion, durations[:, None], amax).peaks()
        return np.maximum(vel / vmax, acc / amax).max(axis=1) - 1.0

    found = timing.shortest_feasible(excess)
    if found is None:
        raise JointRateLimit(
            f"no {kind} duration up to {timing.MAX_DURATION:g} s keeps every joint within its "
            "velocity and acceleration limits with these boundary conditions"
        )
    return found


def plan_joint(
    kind: str,
    motion: PointToPoint,
    limits: JointLimits | None = None,
    *,
    duration: float | None = None,
    sample_period: float | None = None,
    samples: int | None = None,
    max_points: int = MAX_POINTS,
    joint_names: tuple[str, ...] = (),
) -> JointPlan:
    """Plan and sample a point-to-point move: the one core call of the joint-space route.

    Without ``duration`` [s], the shortest one within the velocity/acceleration ``limits``; with
    it, a plan over known limits is ``JointRateLimit`` (naming the shortest feasible duration).
    Boundary positions and every sample must stay within ``limits.position`` (``JointLimit``);
    boundary rates must be within the rate limits (``JointRateLimit``) and honoured by the profile
    (``BOUNDARY_RATES``; ``InputError`` naming the field otherwise). Sampling as ``sample_times``.
    """
    limits = limits or JointLimits()
    dof, names = motion.dof, tuple(joint_names) or default_joint_names(motion.dof)
    if kind not in PROFILES:
        raise InputError(f"profile must be one of {', '.join(PROFILES)}", field=("profile",))
    if len(names) != dof:
        raise InputError(f"{dof} positions for {len(names)} joints", field=("start", "positions"))
    limits.validate(dof)
    _check_boundaries(kind, motion, limits, names)
    amax = limits.maxima(dof)[1]
    rated = limits.velocity is not None or limits.acceleration is not None  # else nothing to check
    if duration is None:
        duration = timing.clamp_duration(
            shortest_duration(kind, motion, limits), f"this {kind} move"
        )
        profile = build_profile(kind, motion, duration, amax)
    else:
        if not (np.isfinite(duration) and 0.0 < duration <= timing.MAX_DURATION):
            raise InputError("duration must be > 0 s and at most 1e5 s", field=("duration",))
        profile = build_profile(kind, motion, duration, amax)
        if rated:
            hint = lambda: _shortest_hint(kind, motion, limits)  # noqa: E731
            check_rates(*_rated(kind, profile.peaks()), limits, names, hint=hint)
    times = sample_times(duration, sample_period, samples, max_points)
    trajectory = Trajectory.from_profile(profile, times, names)
    if rated:
        check_rates(
            *_rated(kind, (trajectory.peak_velocity, trajectory.peak_acceleration)), limits, names
        )
    check_positions(trajectory.positions, limits, names, times=times)
    return JointPlan(trajectory, profile, _warnings(kind, motion))


def _check_boundaries(kind: str, m: PointToPoint, limits: JointLimits, names: tuple) -> None:
    maxima = {"velocities": limits.velocity, "accelerations": limits.acceleration}
    for end, state in (("start", m.start), ("goal", m.goal)):
        check_positions(state.positions[None], limits, names, field=(end, "positions"))
        for what, limit in maxima.items():
            value = getattr(state, what)
            if value.any() and what not in BOUNDARY_RATES[kind]:
                raise InputError(f"the {kind} profile takes no non-zero {what}", field=(end, what))
            if limit is not None:  # an unknown limit is infinite: nothing to check
                check_boundary_rates(value, np.asarray(limit, dtype=float), (end, what), names)


def _rated(kind: str, peaks: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray | None]:
    """The peaks a profile is held to: linear on velocity only (its steps are declared)."""
    return peaks[0], None if kind == "linear" else peaks[1]


def _shortest_hint(kind: str, motion: PointToPoint, limits: JointLimits) -> str:
    try:
        shortest = max(shortest_duration(kind, motion, limits), timing.MIN_DURATION)
    except (InputError, JointRateLimit):
        return ""
    return f"; the shortest {kind} duration within the limits is {shortest:.6g} s"


def _warnings(kind: str, m: PointToPoint) -> tuple[str, ...]:
    out = []
    if kind == "linear":
        out.append(
            "linear: the velocity steps from 0 to |dq|/T at the start and back to 0 at the end "
            "(unbounded acceleration at those instants); reported accelerations are 0"
        )
    if np.any(m.goal.velocities):
        out.append(timing.NONZERO_END_VELOCITY)
    return tuple(out)
