"""Planning a point-to-point joint move: the checks, the profile from the registry, sampling.

``plan_joint`` is the one core call of ``POST /v1/trajectories/joint``: it validates the move
against the profile and the limits, lets the ``PROFILES`` entry time and build the profile (the
shortest duration within the limits when none is given), samples it, and verifies the exact peaks
and the samples against the limits. Units: [rad or m], [s]; arrays ``(dof,)`` or ``(N, dof)``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.collisions import ClearanceReport, End, check_ends, checked
from core.errors import InputError
from core.joint.effort import TimeScaled, peak_effort, shortest_for_effort
from core.joint.motion import PointToPoint, State
from core.joint.profiles import PROFILES
from core.kinematics import Clearance, Dynamics
from core.limits import JointLimits, check_boundary_rates, check_positions, check_rates
from core.timing.path_constraints import Effort
from core.trajectory import MAX_POINTS, Profile, Trajectory, default_joint_names, sample_times

__all__ = ["PROFILES", "JointPlan", "PointToPoint", "State", "plan_joint"]

NO_LIMITS = JointLimits()
"""No limit known (every one infinite)."""


class JointPlan(NamedTuple):
    """A planned move: the sampled ``trajectory`` (with the profile's exact peaks), the
    ``profile`` (sample it anywhere in ``[0, T]``), human-readable ``warnings`` and the collision
    check's ``clearance`` (None: nothing checked), ``peak_effort`` ``(dof,)`` [N m or N] with
    dynamics."""

    trajectory: Trajectory
    profile: Profile
    warnings: tuple[str, ...]
    clearance: ClearanceReport | None = None
    peak_effort: np.ndarray | None = None


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
    deadline: Deadline = NO_DEADLINE,
    effort: Effort | None = None,
    collision_check: Clearance | None = None,
    dynamics: Dynamics | None = None,
    gravity: np.ndarray | None = None,
) -> JointPlan:
    """Plan and sample a point-to-point move: the one core call of the joint-space route.

    Without ``duration`` [s], the shortest one within the ``limits``; with it, a plan over known
    limits is ``JointRateLimit`` (``Infeasible`` for ``jerk_limited``), naming the shortest feasible
    duration. Boundary positions and every sample must stay within ``limits.position``
    (``JointLimit``); boundary rates must be within the rate limits (``JointRateLimit``) and
    honoured by the profile (``ProfileKind.boundary_rates``; ``InputError`` naming the field
    otherwise). Sampling as ``sample_times``. ``deadline`` is checked after the timing and after
    the sampling (``TimeBudgetExceeded``). With ``effort`` (no ``duration``), the shortest
    duration whose inverse-dynamics torque keeps the effort limits too
    (``core.joint.effort.shortest_for_effort``).
    With ``collision_check`` the start and goal are
    checked before planning and the sampled motion continuously after it (``core.collisions``:
    ``Collision`` at the first contact). With ``dynamics``, ``peak_effort`` under ``gravity``
    [m/s^2] (base frame), measured between the returned points too.
    """
    limits = limits or NO_LIMITS
    dof, names = motion.dof, tuple(joint_names) or default_joint_names(motion.dof)
    spec = PROFILES.get(kind)
    if spec is None:
        raise InputError(f"profile must be one of {', '.join(PROFILES)}", field=("profile",))
    if len(names) != dof:
        raise InputError(f"{dof} positions for {len(names)} joints", field=("start", "positions"))
    limits.validate(dof)
    _check_boundaries(kind, motion, limits, names)
    if effort is not None and duration is not None:
        raise InputError(
            "limits.effort applies when the service chooses the duration (give no duration)",
            field=("limits", "effort"),
        )
    ends = (End("start", motion.start.positions, 0.0), End("goal", motion.goal.positions))
    check_ends(collision_check, ends)
    profile = spec.timed(motion, limits, duration, names)
    if effort is not None:
        base = profile
        profile = shortest_for_effort(  # type: ignore[assignment]
            (lambda T: TimeScaled(base, T))
            if motion.at_rest
            else (lambda T: spec.timed(motion, limits, T, names)),
            profile.duration,
            effort,
            names,
            deadline,
        )
    deadline.check("joint profile timing")
    times = sample_times(profile.duration, sample_period, samples, max_points)
    trajectory = Trajectory.from_profile(profile, times, names)
    deadline.check("joint profile sampling")
    if limits.velocity is not None or limits.acceleration is not None or limits.jerk is not None:
        held = spec.held(profile.peaks())
        check_rates(
            held["peak_velocity"], held["peak_acceleration"], limits, names,
            peak_jerk=held["peak_jerk"],
        )  # fmt: skip
    check_positions(trajectory.positions, limits, names, times=times)
    report = checked(trajectory, collision_check)
    peak = peak_effort(dynamics, profile, times, gravity)
    return JointPlan(trajectory, profile, spec.warnings(motion), report, peak)


def _check_boundaries(kind: str, m: PointToPoint, limits: JointLimits, names: tuple) -> None:
    maxima = {"velocities": limits.velocity, "accelerations": limits.acceleration}
    spec = PROFILES[kind]
    for end, state in (("start", m.start), ("goal", m.goal)):
        check_positions(state.positions[None], limits, names, field=(end, "positions"))
        for what, limit in maxima.items():
            value = getattr(state, what)
            if what not in spec.boundary_rates and value.any():
                raise InputError(f"the {kind} profile takes no non-zero {what}", field=(end, what))
            if limit is not None and spec.rates_checked_here:  # unknown limit: infinite
                check_boundary_rates(value, np.asarray(limit, dtype=float), (end, what), names)
