"""What every joint profile shares: exact boundary values at the ends, and the ``ProfileKind``
interface of the ``PROFILES`` registry.

A ``ProfileKind`` turns a ``PointToPoint`` move and ``JointLimits`` into a profile (built once,
sampled many times: ``profile(t, order)`` -> ``(len(t), dof)``, ``profile.sample(t)``, exact
``profile.peaks()``). ``DurationProfileKind`` is the base of the profiles whose only free parameter
is the duration: a given duration is checked against the limits (naming the shortest feasible one),
a missing one is the shortest within them. Units: [rad or m], [s].
"""

from __future__ import annotations

import numpy as np

from core.errors import InputError, JointRateLimit
from core.joint import durations
from core.joint.motion import PointToPoint
from core.limits import JointLimits, check_rates
from core.trajectory import Peaks, Profile


class EndPinned:
    """Shared sampling: profile-specific values, with the exact boundary conditions at 0 and T."""

    duration: float
    _start: tuple[np.ndarray | None, ...]
    _goal: tuple[np.ndarray | None, ...]

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return self._pin(self._ends(t), order, self._evaluate(t, order))

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations at ``t`` ``(N,)``, each ``(N, dof)``: the same as
        three calls, sharing the work they have in common."""
        t = np.asarray(t, dtype=float)
        ends = self._ends(t)
        q, qd, qdd = self._evaluate_orders(t)
        return self._pin(ends, 0, q), self._pin(ends, 1, qd), self._pin(ends, 2, qdd)

    def peaks(self) -> Peaks:
        raise NotImplementedError

    def switch_times(self) -> np.ndarray:
        """Times [s] inside (0, duration) where a derivative up to the jerk steps: none for a
        polynomial (its ends are the profile's own)."""
        return np.zeros(0)

    def _evaluate_orders(self, t: np.ndarray) -> tuple[np.ndarray, ...]:
        return tuple(self._evaluate(t, order) for order in range(3))

    def _ends(self, t: np.ndarray) -> tuple[list[int], list[int]]:
        """Indices of the samples at exactly 0 and exactly ``T`` (usually one each: plain ints
        index a row several times faster than an index array)."""
        return (t == 0.0).nonzero()[0].tolist(), (t == self.duration).nonzero()[0].tolist()

    def _pin(self, ends: tuple[list[int], list[int]], order: int, out: np.ndarray) -> np.ndarray:
        if order < len(self._start):
            for hit, value in zip(ends, (self._start[order], self._goal[order]), strict=True):
                if value is not None:
                    for row in hit:
                        out[row] = value
        return out

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        raise NotImplementedError


class ProfileKind:
    """One entry of ``PROFILES``: how a named profile is timed and built.

    Attributes:
        name: The API name (``"quintic"``).
        boundary_rates: The non-zero boundary rates it honours (``"velocities"``,
            ``"accelerations"``); a non-zero value of any other is 422 ``validation``.
        rated: The peaks held to the limits (``linear`` declares its velocity steps: velocity only).
        rates_checked_here: Boundary rates over the limits are 422 ``joint_rate_limit`` before
            planning (False: the profile reports them itself).
    """

    name: str = ""
    boundary_rates: tuple[str, ...] = ()
    rated: tuple[str, ...] = ("velocity", "acceleration")
    rates_checked_here: bool = True

    def timed(
        self,
        motion: PointToPoint,
        limits: JointLimits,
        duration: float | None,
        joint_names: tuple[str, ...],
    ) -> Profile:
        """The profile of ``motion``: lasting ``duration`` [s], or the shortest within ``limits``."""
        raise NotImplementedError

    def warnings(self, motion: PointToPoint) -> tuple[str, ...]:
        """Things a client should know about this profile of ``motion``."""
        out = []
        if np.count_nonzero(motion.goal.velocities):
            out.append(durations.NONZERO_END_VELOCITY)
        return tuple(out)

    def held(self, peaks: Peaks) -> dict[str, np.ndarray | None]:
        """``check_rates`` keyword arguments of the peaks this profile is held to."""
        return {f"peak_{k}": getattr(peaks, k) if k in self.rated else None for k in Peaks._fields}


class DurationProfileKind(ProfileKind):
    """A profile whose free parameter is the duration: subclasses give ``build`` and
    ``shortest_duration``; ``needs`` names the limit the shortest duration cannot do without."""

    needs: str | None = None

    def build(
        self, motion: PointToPoint, duration: float | np.ndarray, max_acceleration: np.ndarray
    ) -> Profile:
        """The profile lasting ``duration`` [s] (``(G, 1)``: ``G`` candidates at once, for the
        peaks only); ``max_acceleration`` ``(dof,)`` (``inf`` where unknown) sets ramps."""
        raise NotImplementedError

    def shortest_duration(self, motion: PointToPoint, limits: JointLimits) -> float:
        """Shortest ``T`` [s] within the velocity/acceleration ``limits`` (before the
        ``MIN_DURATION`` floor); ``InputError`` naming ``limits`` when they are missing."""
        if self.needs and getattr(limits, self.needs) is None:
            raise InputError(
                f"the {self.name} profile needs limits.{self.needs} or a duration",
                field=("limits", self.needs),
            )
        if limits.velocity is None and limits.acceleration is None:
            raise InputError(
                "give a duration, or limits (or a robot) to time the move", field=("limits",)
            )
        return self._shortest(motion, limits)

    def _shortest(self, motion: PointToPoint, limits: JointLimits) -> float:
        raise NotImplementedError

    def timed(
        self,
        motion: PointToPoint,
        limits: JointLimits,
        duration: float | None,
        joint_names: tuple[str, ...],
    ) -> Profile:
        """Without ``duration`` the shortest one within ``limits``; with it, a plan over known
        limits is ``JointRateLimit`` naming the shortest feasible duration."""
        # ramps only: the acceleration limits, infinite where unknown
        amax = np.asarray(np.inf if limits.acceleration is None else limits.acceleration, float)
        if duration is None:
            shortest = self.shortest_duration(motion, limits)
            return self.build(
                motion, durations.clamp_duration(shortest, f"this {self.name} move"), amax
            )
        if not (np.isfinite(duration) and 0.0 < duration <= durations.MAX_DURATION):
            raise InputError("duration must be > 0 s and at most 1e5 s", field=("duration",))
        profile = self.build(motion, duration, amax)
        if limits.velocity is not None or limits.acceleration is not None:
            try:
                held = self.held(profile.peaks())
                check_rates(
                    held["peak_velocity"],
                    held["peak_acceleration"],
                    limits,
                    joint_names,
                    peak_jerk=held["peak_jerk"],
                )
            except JointRateLimit as err:
                raise self._with_min_duration(err, motion, limits) from None
        return profile

    def _with_min_duration(
        self, err: JointRateLimit, motion: PointToPoint, limits: JointLimits
    ) -> JointRateLimit:
        """``err`` at ``duration``, naming the shortest feasible duration in its detail and as
        ``min_duration`` [s] (the key every problem body uses for it) when there is one."""
        try:
            shortest = max(self.shortest_duration(motion, limits), durations.MIN_DURATION)
        except (InputError, JointRateLimit):
            shortest = None
        extra = dict(err.extra)
        if shortest is None:
            hint = ""
        elif not shortest <= durations.MAX_DURATION:
            hint = f"; within the limits it would take more than {durations.MAX_DURATION:g} s"
        else:
            hint = f"; the shortest {self.name} duration within the limits is {shortest:.6g} s"
            extra["min_duration"] = shortest
        return JointRateLimit(err.detail + hint, field=("duration",), joint=err.joint, extra=extra)
