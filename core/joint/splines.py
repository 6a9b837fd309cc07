"""C2 cubic splines through via points, their boundary conditions, and time allocation under limits.

n + 1 knots, n cubics, 4n unknowns: C2 at the interior knots plus one condition per end (course
notes section 6). scipy's ``CubicSpline`` solves it exactly; this module picks the knot times when
the client gives none, and checks the result against the limits. Boundary conditions:

- ``clamped``: end velocities given (default zero, a rest-to-rest plan);
- ``natural``: zero end accelerations (end velocities free, so the plan does not end at rest);
- ``not-a-knot``: the first two and the last two pieces are one cubic each. With 2 waypoints scipy
  returns the straight line (as for ``natural``), with 3 the single parabola through them.

Units: positions [rad or m], times [s]; waypoints ``(n + 1, dof)``, knot times ``(n + 1,)``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.collisions import ClearanceReport, End, check_ends, checked
from core.errors import Infeasible, InputError, JointRateLimit, PlanningError
from core.joint import durations
from core.joint.effort import peak_effort, shortest_for_effort
from core.joint.spline_profile import BOUNDARIES, SplineProfile
from core.kinematics import Clearance, Dynamics
from core.limits import (
    JointLimits,
    check_boundary_rates,
    check_positions,
    check_rates,
    joint_vector,
)
from core.timing.path_constraints import Effort
from core.trajectory import MAX_POINTS, Trajectory, default_joint_names, sample_times

MIN_KNOT_SPACING = 1e-6
"""Smallest interval [s] between two given knot times."""
SHAPE_ITERATIONS = 8
"""Rounds of segment-wise re-allocation before the final uniform scaling."""


class SplinePlan(NamedTuple):
    """A planned spline: the sampled ``trajectory``, the ``profile``, its ``knot_times`` [s]
    ``(n + 1,)``, ``warnings``, the collision check's ``clearance``, ``peak_effort`` [N m or N]."""

    trajectory: Trajectory
    profile: SplineProfile
    knot_times: np.ndarray
    warnings: tuple[str, ...]
    clearance: ClearanceReport | None = None
    peak_effort: np.ndarray | None = None


ROUNDING_MARGIN = 1e-12
"""Relative lengthening of an exactly scaled spline, so its peaks are never above the limits by
rounding (a natural spline timed to 1 rad/s peaked at 1.0000000000000002)."""


def _segment_ratios(profile: SplineProfile, vmax: np.ndarray, amax: np.ndarray) -> np.ndarray:
    """Per piece, the factor by which stretching time would just meet the limits, ``(n,)``."""
    vel, acc = profile.segment_peaks()
    return np.maximum(vel / vmax, np.sqrt(acc / amax)).max(axis=1)


def allocate_times(
    waypoints: np.ndarray,
    boundary: str,
    limits: JointLimits,
    start_velocity: np.ndarray | None = None,
    goal_velocity: np.ndarray | None = None,
    deadline: Deadline = NO_DEADLINE,
) -> np.ndarray:
    """Knot times ``(n + 1,)`` [s] so the spline keeps within the velocity/acceleration limits.

    Start: each piece gets the slowest joint's ``max(|dq|/vmax, 2 sqrt(|dq|/amax))`` (at least 5 %
    of the longest piece). Scaling every time by ``k`` scales velocities by ``1/k`` and
    accelerations by ``1/k^2``, so the exact factor follows from the exact peaks of each piece
    (not only at the knots). A few rounds shrink the pieces with slack relative to the binding one;
    the shortest total after exact scaling wins, so the binding limit is reached. With non-zero
    clamped end velocities scaling is not exact, and the total is found by ``shortest_feasible``
    (first within a factor 4 of the estimate, then over the whole range).
    ``deadline`` is checked between fits (``TimeBudgetExceeded``).
    """
    dof = waypoints.shape[1]
    vmax, amax = limits.maxima(dof)
    if limits.velocity is None and limits.acceleration is None:
        raise InputError("give times, or limits (or a robot) to time the spline", field=("limits",))
    dq = np.abs(np.diff(waypoints, axis=0))
    # No piece is faster than its distance over the speed limit: a sum of those beyond the longest
    # duration is infeasible before any fit (a URDF's 1e-300 rad/s would overflow the knot times).
    with np.errstate(over="ignore"):
        lower = float((dq / vmax).max(axis=1).sum())
    if not lower <= durations.MAX_DURATION:
        raise Infeasible(
            f"this spline needs more than {durations.MAX_DURATION:g} s under these limits",
            field=("limits",),
        )
    h = np.maximum(dq / vmax, 2.0 * np.sqrt(dq / amax)).max(axis=1)
    h = np.maximum(h, 0.05 * h.max()) if h.max() > 0.0 else np.ones_like(h)

    def fit(pieces: np.ndarray) -> SplineProfile:
        deadline.check("spline time allocation")
        knots = np.concatenate([[0.0], np.cumsum(pieces)])
        return SplineProfile(knots, waypoints, boundary, start_velocity, goal_velocity)

    best = h
    best_total = np.inf
    for _ in range(SHAPE_ITERATIONS):
        ratios = _segment_ratios(fit(h), vmax, amax)
        k = ratios.max()
        if k <= 0.0:
            break
        if k * h.sum() < best_total:
            best, best_total = h * k, k * h.sum()
        h = h * np.clip(ratios / k, 0.25, 1.0) ** 0.5
    homogeneous = boundary != "clamped" or not (np.any(start_velocity) or np.any(goal_velocity))
    if homogeneous:
        # 1e-12 longer: the exact scaling meets the binding limit, rounding may put it an ulp over
        scaled_total = durations.clamp_duration(
            best_total * (1.0 + ROUNDING_MARGIN) if np.isfinite(best_total) else 0.0, "this spline"
        )
        return np.concatenate([[0.0], np.cumsum(best * (scaled_total / best.sum()))])

    def excess(totals: np.ndarray) -> np.ndarray:
        scaled = (best * (d / best.sum()) for d in totals)
        return np.array([_segment_ratios(fit(p), vmax, amax).max() for p in scaled]) - 1.0

    lower = max(durations.MIN_DURATION, best_total / 4.0)
    upper = min(durations.MAX_DURATION, best_total * 4.0)
    total: float | None = (
        durations.shortest_feasible(excess, lower, upper, grid_points=25) if lower < upper else None
    )
    if total is None or total == lower:  # nothing near the estimate, or maybe shorter below it
        total = durations.shortest_feasible(excess)
    if total is None:
        raise JointRateLimit(
            f"no spline duration up to {durations.MAX_DURATION:g} s keeps every joint within its "
            "limits with these end velocities"
        )
    return np.concatenate([[0.0], np.cumsum(best * (total / best.sum()))])


def plan_spline(
    waypoints: np.ndarray,
    *,
    times: np.ndarray | None = None,
    boundary: str = "clamped",
    start_velocity: np.ndarray | None = None,
    goal_velocity: np.ndarray | None = None,
    limits: JointLimits | None = None,
    sample_period: float | None = None,
    samples: int | None = None,
    max_points: int = MAX_POINTS,
    joint_names: tuple[str, ...] = (),
    deadline: Deadline = NO_DEADLINE,
    effort: Effort | None = None,
    collision_check: Clearance | None = None,
    dynamics: Dynamics | None = None,
    gravity: np.ndarray | None = None,
) -> SplinePlan:
    """Plan and sample a spline through ``waypoints`` ``(n + 1, dof)``: the one core call of the
    spline route.

    Without ``times``, knot times from ``allocate_times`` (with ``effort``, scaled until the
    inverse-dynamics torque keeps the effort limits too); with them, a plan over known limits is
    ``JointRateLimit``. Waypoints and every sample must stay within ``limits.position``
    (``JointLimit``). End velocities are for ``clamped`` only (``InputError`` otherwise). With
    ``collision_check``, the first and last waypoints are checked before planning and the sampled
    motion continuously after it (``core.collisions``). ``dynamics``: ``peak_effort`` (``gravity``).
    """
    limits = limits or JointLimits()
    q, names, v0, v1 = _entry(
        waypoints, boundary, start_velocity, goal_velocity, limits, joint_names
    )
    if effort is not None and times is not None:
        raise InputError(
            "limits.effort applies when the service allocates the times (give no times)",
            field=("limits", "effort"),
        )
    check_ends(collision_check, (End("start", q[0], 0.0), End("goal", q[-1])))
    profile, knots = _timed(q, times, boundary, v0, v1, limits, names, effort, deadline)
    trajectory = Trajectory.from_profile(
        profile, sample_times(profile.duration, sample_period, samples, max_points), names
    )
    if limits.velocity is not None or limits.acceleration is not None:  # else nothing to check
        check_rates(trajectory.peak_velocity, trajectory.peak_acceleration, limits, names)
    check_positions(trajectory.positions, limits, names, times=trajectory.times)
    warnings = () if not np.any(trajectory.velocities[-1]) else (durations.NONZERO_END_VELOCITY,)
    report = checked(trajectory, collision_check)
    peak = peak_effort(dynamics, profile, trajectory.times, gravity)
    return SplinePlan(trajectory, profile, knots, warnings, report, peak)


def _entry(
    waypoints: np.ndarray,
    boundary: str,
    start_velocity: np.ndarray | None,
    goal_velocity: np.ndarray | None,
    limits: JointLimits,
    joint_names: tuple[str, ...],
) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, np.ndarray]:
    """``plan_spline``'s entry checks: waypoints ``(n + 1, dof)``, joint names, end velocities
    ``(dof,)`` (``InputError``, ``JointLimit``, ``JointRateLimit`` naming the field)."""
    q = np.asarray(waypoints, dtype=float)
    if q.ndim != 2 or q.shape[0] < 2 or q.shape[1] < 1 or not np.all(np.isfinite(q)):
        raise InputError("waypoints must be 2 or more finite joint vectors", field=("waypoints",))
    dof, names = q.shape[1], tuple(joint_names) or default_joint_names(q.shape[1])
    if len(names) != dof:
        raise InputError(
            f"waypoints have {dof} values for {len(names)} joints", field=("waypoints", 0)
        )
    if boundary not in BOUNDARIES:
        raise InputError(f"boundary must be one of {', '.join(BOUNDARIES)}", field=("boundary",))
    if boundary != "clamped":
        for name, value in (("start_velocity", start_velocity), ("goal_velocity", goal_velocity)):
            if value is not None:
                raise InputError(f"{name} applies to a clamped spline only", field=(name,))
    v0 = joint_vector(start_velocity, dof, ("start_velocity",), default=0.0)
    v1 = joint_vector(goal_velocity, dof, ("goal_velocity",), default=0.0)
    limits.validate(dof)
    check_positions(q, limits, names, field=("waypoints",))
    vmax = limits.maxima(dof)[0]
    check_boundary_rates(v0, vmax, ("start_velocity",), names)
    check_boundary_rates(v1, vmax, ("goal_velocity",), names)
    return q, names, v0, v1


def _timed(
    q: np.ndarray,
    times: np.ndarray | None,
    boundary: str,
    v0: np.ndarray,
    v1: np.ndarray,
    limits: JointLimits,
    names: tuple[str, ...],
    effort: Effort | None,
    deadline: Deadline,
) -> tuple[SplineProfile, np.ndarray]:
    """The spline's profile and knot times [s]: allocated within the limits (and ``effort``)
    without ``times``; else at ``times``, checked against the rate limits."""
    if times is None:
        knots = allocate_times(q, boundary, limits, v0, v1, deadline)
        profile = SplineProfile(knots, q, boundary, v0, v1)
        if effort is not None:
            shape = knots / knots[-1]
            profile = shortest_for_effort(  # type: ignore[assignment]
                lambda T: SplineProfile(shape * T, q, boundary, v0, v1),
                profile.duration,
                effort,
                names,
                deadline,
            )
            knots = profile.knot_times
        return profile, knots
    knots = _knot_times(times, q.shape[0])
    profile = SplineProfile(knots, q, boundary, v0, v1)

    def hint() -> str:
        try:
            allocated = allocate_times(q, boundary, limits, v0, v1, deadline)[-1]
        except PlanningError:
            return ""
        return f"; times allocated within the limits would take {allocated:.6g} s"

    if limits.velocity is not None or limits.acceleration is not None:
        vel, acc = (peak.max(axis=0) for peak in profile.segment_peaks())
        check_rates(vel, acc, limits, names, hint=hint)
    return profile, knots


def _knot_times(times: object, count: int) -> np.ndarray:
    """Given knot times as ``(count,)``, from 0, strictly increasing by at least 1 us, finite."""
    t = np.asarray(times, dtype=float)
    if t.shape != (count,):
        raise InputError(f"times needs {count} values, one per waypoint", field=("times",))
    if not np.all(np.isfinite(t)) or t[-1] > durations.MAX_DURATION:
        raise InputError(
            f"times must be finite and at most {durations.MAX_DURATION:g} s", field=("times",)
        )
    if t[0] != 0.0:
        raise InputError("times must start at 0.0", field=("times", 0))
    short = np.flatnonzero(np.diff(t) < MIN_KNOT_SPACING)
    if short.size:
        i = int(short[0]) + 1
        raise InputError(
            f"times must increase by at least {MIN_KNOT_SPACING:g} s", field=("times", i)
        )
    return t
