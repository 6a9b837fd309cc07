"""The jerk-limited point-to-point profile (registry entry ``jerk_limited``), on Ruckig.

Ruckig (pip ``ruckig``; Berscheid and Kroeger, "Jerk-limited real-time trajectory generation with
arbitrary target states", RSS 2021) gives the time-optimal profile under per-joint velocity,
acceleration and jerk limits from any start state to any goal state, with every joint synchronized
to finish together; ``minimum_duration`` stretches it to a given duration. Each joint's profile is
seven phases of constant jerk, so positions are piecewise cubic: this module reads the phases
(``Trajectory.profiles``) and samples them vectorized (the same arithmetic as Ruckig's ``at_time``,
without one Python call per sample), with the exact boundary states at ``t == 0`` and ``t == T``,
and the exact peaks of every phase.

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
from core.trajectory import Peaks

RUCKIG_MAX_DURATION = 7600.0
"""[s] Ruckig refuses longer trajectories (numerical stability; its ``ErrorTrajectoryDuration``)."""
DURATION_TOLERANCE = 1e-9
"""Relative: a Ruckig duration this close to the requested one is the requested one."""
PHASES = 7


class JerkLimitedProfile:
    """A synchronized Ruckig profile: per joint, seven phases of constant jerk.

    Args:
        trajectory: A calculated ``ruckig.Trajectory`` (one section, no brake phase).
        start, goal: The boundary states, returned exactly at ``t == 0`` and ``t == duration``.
        duration: The duration [s] to report (Ruckig's, or the requested one it equals to
            ``DURATION_TOLERANCE``).
    """

    method = "jerk_limited"

    def __init__(
        self, trajectory: ruckig.Trajectory, start: State, goal: State, duration: float
    ) -> None:
        phases = trajectory.profiles[0]
        # (dof, 7) phase durations and jerks; (dof, 8) states at the phase boundaries.
        self.phase_durations = np.array([p.t for p in phases])
        self.jerk = np.array([p.j for p in phases])
        self.acc = np.array([p.a for p in phases])
        self.vel = np.array([p.v for p in phases])
        self.pos = np.array([p.p for p in phases])
        self.starts = np.concatenate(
            [np.zeros((len(phases), 1)), np.cumsum(self.phase_durations, axis=1)[:, :-1]], axis=1
        )
        self.duration = float(duration)
        self._start, self._goal = start, goal

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """Derivative ``order`` (0-3) at times ``t`` ``(N,)`` [s] -> ``(N, dof)``."""
        return self._evaluate(np.asarray(t, dtype=float), (order,))[0]

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations at ``t`` ``(N,)``, each ``(N, dof)``."""
        q, qd, qdd = self._evaluate(np.asarray(t, dtype=float), (0, 1, 2))
        return q, qd, qdd

    def _evaluate(self, t: np.ndarray, orders: tuple[int, ...]) -> list[np.ndarray]:
        dof = self.jerk.shape[0]
        # Phase of every (sample, joint): searchsorted per joint (phase starts differ per joint).
        k = np.empty((t.size, dof), dtype=np.intp)
        for j in range(dof):
            k[:, j] = np.searchsorted(self.starts[j], t, side="right") - 1
        np.clip(k, 0, PHASES - 1, out=k)
        cols = np.arange(dof)
        tau = np.clip(t, 0.0, self.duration)[:, None] - self.starts[cols, k]
        jk, ak, vk, pk = (x[cols, k] for x in (self.jerk, self.acc, self.vel, self.pos))
        out = []
        for order in orders:
            if order == 0:
                value = pk + tau * (vk + tau * (ak / 2.0 + tau * jk / 6.0))
            elif order == 1:
                value = vk + tau * (ak + tau * jk / 2.0)
            elif order == 2:
                value = ak + tau * jk
            else:
                value = jk.copy()
            if order < 3:
                ends = (self._start[order], self._goal[order])
                for at, state in zip((0.0, self.duration), ends, strict=True):
                    hit = (t == at).nonzero()[0]
                    if hit.size:
                        value[hit] = state
            out.append(value)
        return out

    def peaks(self) -> Peaks:
        """Exact largest |velocity|, |acceleration|, |jerk| of each joint ``(dof,)``: jerk over
        the phases of non-zero length, acceleration at the phase boundaries (linear in between),
        velocity at the boundaries and where the acceleration crosses zero inside a phase."""
        live = self.phase_durations > 0.0
        jerk = np.where(live, np.abs(self.jerk), 0.0).max(axis=1)
        acc = np.abs(self.acc).max(axis=1)
        a, j, h = self.acc[:, :-1], self.jerk, self.phase_durations
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = -a / j
            inside = live & (j != 0.0) & (tau > 0.0) & (tau < h)
            v_turn = np.where(inside, np.abs(self.vel[:, :-1] - a * a / (2.0 * j)), 0.0)
        vel = np.maximum(np.abs(self.vel).max(axis=1), v_turn.max(axis=1))
        return Peaks(vel, acc, jerk)


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
            inp.minimum_duration = max(float(duration), durations.MIN_DURATION)
        trajectory = _calculate(inp, joint_names)
        found = trajectory.duration
        if duration is None:
            if found < durations.MIN_DURATION:  # no motion: stretch to the floor
                inp.minimum_duration = durations.MIN_DURATION
                trajectory = _calculate(inp, joint_names)
            return JerkLimitedProfile(
                trajectory, motion.start, motion.goal, max(found, durations.MIN_DURATION)
            )
        if abs(found - duration) > DURATION_TOLERANCE * duration:
            inp.minimum_duration = None
            shortest = _calculate(inp, joint_names).duration
            blocked = (
                ""
                if found <= shortest * (1.0 + DURATION_TOLERANCE)
                else f" (with these boundary states the next feasible duration is {found:.6g} s)"
            )
            raise Infeasible(
                f"no jerk-limited profile lasts {duration:.6g} s within the limits: the shortest "
                f"feasible duration is {shortest:.6g} s{blocked}",
                field=("duration",),
                extra={"shortest_duration": shortest},
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


def _calculate(inp: ruckig.InputParameter, names: tuple[str, ...]) -> ruckig.Trajectory:
    """Ruckig's trajectory for ``inp``; every Ruckig failure as ``Infeasible`` with its reason."""
    dof = len(names)
    trajectory = ruckig.Trajectory(dof)
    try:
        result = ruckig.Ruckig(dof).calculate(inp, trajectory)
    except ruckig.RuckigError as e:  # unreachable target state, the duration cap...
        reason = str(e).replace("[ruckig]", "").strip()
        for j in range(dof - 1, -1, -1):
            reason = reason.replace(f"DoF {j}", f"joint {names[j]}")
        raise Infeasible(f"no jerk-limited profile within the limits: {reason}") from e
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise Infeasible(f"no jerk-limited profile within the limits (Ruckig: {result.name})")
    if trajectory.duration > RUCKIG_MAX_DURATION:
        raise Infeasible(f"the jerk-limited profile would take more than {RUCKIG_MAX_DURATION:g} s")
    if any(p.brake.duration > 0.0 for p in trajectory.profiles[0]):
        raise Infeasible(
            "the start state carries a joint over its velocity or acceleration limit before "
            "the jerk limit lets it brake: no jerk-limited profile stays within the limits"
        )
    return trajectory
