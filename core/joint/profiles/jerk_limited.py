"""The jerk-limited point-to-point profile (registry entry ``jerk_limited``), on Ruckig.

Ruckig (pip ``ruckig``; Berscheid and Kroeger, "Jerk-limited real-time trajectory generation with
arbitrary target states", RSS 2021) gives the time-optimal profile under per-joint velocity,
acceleration and jerk limits from any start state to any goal state, with every joint synchronized
to finish together; ``minimum_duration`` stretches it to a given duration. Each joint's profile is
seven phases of constant jerk (``core.timing.s_curve.ConstantJerkPhases`` samples them vectorized
and gives their exact peaks); this module adds the exact boundary states at ``t == 0`` and
``t == T``.

Failures are never Ruckig exceptions: a boundary state over the limits, a start state that would
carry a joint over its velocity limit before it can brake, a goal state that cannot be reached
within the limits, a duration shorter than the time-optimal one, or Ruckig's 7,600 s cap are all
``Infeasible`` with the reason. Units: [rad or m], [s]; limits per [s], [s^2], [s^3].
"""

from __future__ import annotations

import numpy as np
import ruckig

from core.errors import Infeasible, InputError
from core.joint import durations
from core.joint.motion import PointToPoint, State
from core.joint.profiles.base import ProfileKind
from core.limits import JointLimits
from core.timing.s_curve import DURATION_TOLERANCE, ConstantJerkPhases, calculate


class JerkLimitedProfile(ConstantJerkPhases):
    """A synchronized Ruckig profile: per joint, seven phases of constant jerk, sampled with the
    exact boundary states at ``t == 0`` and ``t == duration``.

    Args:
        trajectory: A calculated ``ruckig.Trajectory`` (one section, no brake phase).
        start, goal: The boundary states.
        duration: The duration [s] to report (Ruckig's, or the requested one it equals to
            ``DURATION_TOLERANCE``).
    """

    method = "jerk_limited"

    def __init__(
        self, trajectory: ruckig.Trajectory, start: State, goal: State, duration: float
    ) -> None:
        super().__init__(trajectory, duration)
        self._start, self._goal = start, goal

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """Derivative ``order`` (0-3) at times ``t`` ``(N,)`` [s] -> ``(N, dof)``."""
        return self._pinned(np.asarray(t, dtype=float), (order,))[0]

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations at ``t`` ``(N,)``, each ``(N, dof)``."""
        q, qd, qdd = self._pinned(np.asarray(t, dtype=float), (0, 1, 2))
        return q, qd, qdd

    def _pinned(self, t: np.ndarray, orders: tuple[int, ...]) -> list[np.ndarray]:
        out = self.evaluate(t, orders)
        ends = [(t == 0.0).nonzero()[0], (t == self.duration).nonzero()[0]]
        for order, value in zip(orders, out, strict=True):
            if order < 3:
                for hit, state in zip(ends, (self._start, self._goal), strict=True):
                    if hit.size:
                        value[hit] = state[order]
        return out


class JerkLimited(ProfileKind):
    """Time-optimal (or exactly ``duration``) jerk-limited profile; every joint finishes together.

    Needs velocity, acceleration and jerk limits (the request's, else the robot's); boundary
    velocities and accelerations may be non-zero.
    """

    name = "jerk_limited"
    boundary_rates = ("velocities", "accelerations")
    rated = ("velocity", "acceleration", "jerk")
    rates_checked_here = False

    def timed(
        self,
        motion: PointToPoint,
        limits: JointLimits,
        duration: float | None,
        joint_names: tuple[str, ...],
    ) -> JerkLimitedProfile:
        """The Ruckig profile; ``Infeasible`` (with the reason) where Ruckig finds none."""
        dof = motion.dof
        vmax, amax, jmax = (
            self._limit(limits, name, dof) for name in ("velocity", "acceleration", "jerk")
        )
        if duration is not None and not (
            np.isfinite(duration) and 0.0 < duration <= durations.MAX_DURATION
        ):
            raise InputError("duration must be > 0 s and at most 1e5 s", field=("duration",))
        _check_boundary_states(motion, vmax, amax, joint_names)
        inp = ruckig.InputParameter(dof)
        inp.current_position = motion.start.positions
        inp.current_velocity = motion.start.velocities
        inp.current_acceleration = motion.start.accelerations
        inp.target_position = motion.goal.positions
        inp.target_velocity = motion.goal.velocities
        inp.target_acceleration = motion.goal.accelerations
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = vmax, amax, jmax
        if duration is not None:
            inp.minimum_duration = float(duration)
        trajectory = calculate(inp, joint_names)
        found = trajectory.duration
        if duration is None:
            if not found > 0.0:  # no motion (within Ruckig's precision): rest for the floor
                inp.minimum_duration = durations.MIN_DURATION
                trajectory = calculate(inp, joint_names)
                found = durations.MIN_DURATION
            return JerkLimitedProfile(trajectory, motion.start, motion.goal, found)
        if abs(found - duration) > DURATION_TOLERANCE * duration:
            inp.minimum_duration = None
            shortest = calculate(inp, joint_names).duration
            blocked = (
                ""
                if found <= shortest * (1.0 + DURATION_TOLERANCE)
                else f" (with these boundary states the next feasible duration is {found:.6g} s)"
            )
            raise Infeasible(
                f"no jerk-limited profile lasts {duration:.6g} s within the limits: the shortest "
                f"feasible duration is {shortest:.6g} s{blocked}",
                field=("duration",),
                extra={"min_duration": shortest},
            )
        return JerkLimitedProfile(trajectory, motion.start, motion.goal, float(duration))

    @staticmethod
    def _limit(limits: JointLimits, name: str, dof: int) -> np.ndarray:
        value = getattr(limits, name)
        if value is None:
            raise InputError(
                f"the jerk_limited profile needs limits.{name} (from the request or the robot)",
                field=("limits", name),
            )
        value = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(value)):
            raise InputError(f"limits.{name} must be finite", field=("limits", name))
        return value


def _check_boundary_states(
    motion: PointToPoint, vmax: np.ndarray, amax: np.ndarray, names: tuple[str, ...]
) -> None:
    """``Infeasible`` naming the field and joint where a boundary state is over its limit."""
    for end, state in (("start", motion.start), ("goal", motion.goal)):
        for what, value, limit in (
            ("velocities", state.velocities, vmax),
            ("accelerations", state.accelerations, amax),
        ):
            over = np.flatnonzero(np.abs(value) > limit)
            if over.size:
                j = int(over[0])
                raise Infeasible(
                    f"{end}.{what} of joint {names[j]} ({value[j]:.6g}) is over its limit "
                    f"({limit[j]:.6g}): no jerk-limited profile starts or ends there",
                    field=(end, what, j),
                    joint=j,
                )
