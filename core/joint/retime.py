"""Retiming a joint path: the geometric path through waypoints, timed at the optimum, sampled.

``plan_retime`` is the one core call of ``POST /v1/trajectories/retime``: it checks the waypoints,
builds the path (``PATHS``: ``spline`` or ``blended``), checks it against the position limits
densely, times it with ``core.timing.topp.time_optimal`` under the joint, tool and effort limits
(with jerk limits, on a spline only, ``core.timing.path_jerk.jerk_limited``), and samples it.
Every returned point lies on the path; the returned times hold, around every grid time where s''
switches, two points ``MIN_SPACING`` apart with the switch exactly between them (so integrating
the returned accelerations between consecutive points by the trapezoid rule gives the returned
velocities: the jump is integrated exactly, and no other point pair holds one), merged with the
requested sampling (other points closer than ``MIN_SPACING`` are one; a jerk-limited motion's s''
never jumps: no pairs). The peaks it reports are measured on the returned motion at ``DENSE``
points between consecutive returned points as well as at them (a jerk-limited motion's jerk
exactly, with its own dense check's peak). Units: [rad or m], [s].
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.collisions import ClearanceReport, End, check_ends, checked
from core.errors import InputError, JointLimit, TooLarge
from core.joint.blended_path import BlendedPath
from core.joint.spline_path import SplinePath
from core.kinematics import Clearance, Dynamics
from core.limits import JointLimits, check_positions, outside
from core.timing.joint_path import JointPath
from core.timing.path_constraints import Effort, PathLimits, ToolSpeed
from core.timing.path_jerk import JerkLimited, jerk_limited
from core.timing.topp import TimeOptimal, time_optimal
from core.trajectory import (
    MAX_POINTS,
    Peaks,
    Trajectory,
    default_joint_names,
    sample_times,
    sampled_peak_jerk,
)

MAX_WAYPOINTS = 10_000
"""Most waypoints of one path."""
DEFAULT_MAX_DEVIATION = 0.1
"""Corner deviation [rad or m] of a ``blended`` path when the request gives none."""
MIN_STEP = 1e-9
"""Consecutive waypoints closer than this [rad or m] are repeated (no direction between them)."""
MIN_SPACING = 1e-6
"""Returned points closer than this [s] are one (a grid time wins over a sample time)."""
DENSE = 3
"""Points between consecutive returned points where the peaks are measured."""
POSITION_CHECKS = 16
"""Checks of the position limits per grid piece of the path."""

PATHS: dict[str, Callable[[np.ndarray, float], JointPath]] = {
    "spline": lambda waypoints, _: SplinePath(waypoints),
    "blended": lambda waypoints, deviation: BlendedPath(waypoints, deviation),
}
"""Path shapes by name: (waypoints ``(n, dof)``, max_deviation) -> ``JointPath``."""
JERK_PATHS = ("spline",)
"""Path shapes that jerk limits apply to (continuous d2q/ds2, bounded d3q/ds3)."""


@dataclass(frozen=True)
class RetimePlan:
    """A retimed path: the sampled ``trajectory`` (its ``peaks`` measured densely), the
    ``timing`` (``TimeOptimal``, or ``JerkLimited`` with jerk limits: binding limits, switch
    times), the ``path``, its ``path_length`` (joint-space arc length [rad or m]),
    ``peak_effort`` ``(dof,)`` [N m or N] (None without dynamics), the ``clearance`` report, and
    ``time_optimal_duration`` [s] of the same path without jerk limits (None when the timing is
    that one)."""

    trajectory: Trajectory
    timing: TimeOptimal | JerkLimited
    path: JointPath
    path_length: float
    peak_effort: np.ndarray | None
    clearance: ClearanceReport | None = None
    time_optimal_duration: float | None = None

    @property
    def timing_name(self) -> str:
        """``"jerk_limited"`` or ``"time_optimal"``: which timing the motion has."""
        return "jerk_limited" if self.time_optimal_duration is not None else "time_optimal"


def check_waypoints(waypoints: object, limits: JointLimits, names: tuple[str, ...]) -> np.ndarray:
    """The waypoints as ``(n, dof)``: 2 to ``MAX_WAYPOINTS`` finite rows of one joint per name,
    consecutive ones at least ``MIN_STEP`` apart, inside the position limits. ``InputError`` (or
    ``JointLimit``) names ``waypoints.i`` (``.j``)."""
    q = np.asarray(waypoints, dtype=float)
    if q.ndim != 2 or not 2 <= len(q) <= MAX_WAYPOINTS or q.shape[1] != len(names):
        raise InputError(
            f"waypoints must be 2 to {MAX_WAYPOINTS} vectors of {len(names)} joint values",
            field=("waypoints",),
        )
    bad = np.flatnonzero(~np.isfinite(q).all(axis=1))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"waypoints.{i} must hold finite numbers", field=("waypoints", i))
    steps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    repeated = np.flatnonzero(steps < MIN_STEP)
    if repeated.size:
        i = int(repeated[0]) + 1
        raise InputError(
            f"waypoints.{i} repeats waypoints.{i - 1}: consecutive waypoints must differ",
            field=("waypoints", i),
        )
    check_positions(q, limits, names, field=("waypoints",))
    return q


def plan_retime(
    waypoints: object,
    limits: JointLimits,
    *,
    path: str = "blended",
    max_deviation: float = DEFAULT_MAX_DEVIATION,
    tool: ToolSpeed | None = None,
    effort: Effort | None = None,
    dynamics: Dynamics | None = None,
    gravity: np.ndarray | None = None,
    sample_period: float | None = None,
    samples: int | None = None,
    max_points: int = MAX_POINTS,
    joint_names: tuple[str, ...] = (),
    deadline: Deadline = NO_DEADLINE,
    collision_check: Clearance | None = None,
) -> RetimePlan:
    """Time the ``path`` through ``waypoints`` at the optimum under ``limits`` (velocity and
    acceleration needed), ``tool`` speeds and ``effort``; ``dynamics`` with ``gravity`` [m/s^2]
    (base frame) measure ``peak_effort``. ``InputError`` names the field at fault; ``JointLimit``
    the ``s`` where a spline leaves the position limits; ``Infeasible`` where no motion keeps the
    limits (or gravity alone exceeds an effort limit). With ``collision_check`` the first and last
    waypoints are checked before timing and the timed motion continuously after it
    (``core.collisions``: ``Collision`` at the first contact)."""
    try:
        shape = np.shape(np.asarray(waypoints, dtype=float))
    except (TypeError, ValueError):
        raise InputError(
            "waypoints must be rows of joint values of one length", field=("waypoints",)
        ) from None
    names = tuple(joint_names) or default_joint_names(int(shape[-1]) if shape else 0)
    if path not in PATHS:
        raise InputError(f"path must be one of {', '.join(PATHS)}", field=("path",))
    limits.validate(len(names))
    if limits.velocity is None or limits.acceleration is None:
        missing = "velocity" if limits.velocity is None else "acceleration"
        raise InputError(f"limits.{missing} is required without a robot", field=("limits", missing))
    jerk = _jerk(limits, path)
    q = check_waypoints(waypoints, limits, names)
    check_ends(collision_check, (End("start", q[0], 0.0), End("goal", q[-1])))
    geometry = PATHS[path](q, float(max_deviation))
    _check_positions(geometry, limits, names)
    path_limits = PathLimits(limits.velocity, limits.acceleration, tool=tool, effort=effort)
    timing: TimeOptimal | JerkLimited
    if jerk is None:
        timing = time_optimal(geometry, path_limits, joint_names=names, deadline=deadline)
    else:
        timing = jerk_limited(geometry, path_limits, jerk, joint_names=names, deadline=deadline)
    deadline.check("retime")
    times = _times(timing, sample_period, samples, max_points)
    q_t, qd_t, qdd_t = timing.sample(times)
    qd_t[0] = qd_t[-1] = 0.0
    dense = times[:-1, None] + np.diff(times)[:, None] * np.arange(1, DENSE + 1) / (DENSE + 1)
    qd_d, qdd_d = timing.sample(dense.ravel())[1:]
    if isinstance(timing, JerkLimited):
        jerks = np.abs(timing.sample_jerk(np.concatenate([times, dense.ravel()])))
        peak_jerk = np.maximum(jerks.max(axis=0), timing.peak_jerk)
    else:
        peak_jerk = sampled_peak_jerk(times, qdd_t)
    peaks = Peaks(
        np.maximum(np.abs(qd_t).max(axis=0), np.abs(qd_d).max(axis=0)),
        np.maximum(np.abs(qdd_t).max(axis=0), np.abs(qdd_d).max(axis=0)),
        peak_jerk,
    )
    trajectory = Trajectory(times, q_t, qd_t, qdd_t, names, peaks)
    peak_effort = None
    if dynamics is not None:
        g = np.zeros(3) if gravity is None else gravity
        q_d = timing.sample(dense.ravel())[0]
        tau = dynamics.inverse_dynamics(
            np.vstack([q_t, q_d]), np.vstack([qd_t, qd_d]), np.vstack([qdd_t, qdd_d]), g
        )
        peak_effort = np.abs(tau).max(axis=0)
    report = checked(trajectory, collision_check)
    length = _arc_length(geometry, timing)
    optimal = timing.time_optimal_duration if isinstance(timing, JerkLimited) else None
    return RetimePlan(trajectory, timing, geometry, length, peak_effort, report, optimal)


def _jerk(limits: JointLimits, path: str) -> np.ndarray | None:
    """The jerk limits to keep (None without any finite one); ``InputError`` at ``limits.jerk``
    on a path whose curvature steps (a blended path's arcs meet its lines with a jump of d2q/ds2:
    the jerk is unbounded there at any speed but zero)."""
    if limits.jerk is None or not np.isfinite(limits.jerk).any():
        return None
    if path not in JERK_PATHS:
        raise InputError(
            "jerk limits need path spline: a blended path's curvature steps where an arc meets a "
            "line, so the jerk there is unbounded at any speed but zero",
            field=("limits", "jerk"),
        )
    return np.asarray(limits.jerk, dtype=float)


def _times(
    timing: TimeOptimal | JerkLimited,
    sample_period: float | None,
    samples: int | None,
    max_points: int,
) -> np.ndarray:
    """The requested sample times merged with a pair of times ``MIN_SPACING`` apart around every
    interior switch time of s'' (the switch exactly between them, so the trapezoid rule over the
    pair integrates the acceleration's jump exactly), or the switch times themselves when the
    pairs would exceed ``max_points``; any other two times closer than ``MIN_SPACING`` are one."""
    base = sample_times(timing.duration, sample_period, samples, max_points)
    switch = timing.switch_times[1:-1]
    half = 0.5 * MIN_SPACING
    wide = np.diff(timing.switch_times)
    alone = (wide[:-1] > 4.0 * MIN_SPACING) & (wide[1:] > 4.0 * MIN_SPACING)
    if len(base) + len(switch) + alone.sum() > max_points:
        alone[:] = False  # no room for pairs: one point at each switch (a path of many pieces)
    pairs = np.concatenate([switch[alone] - half, switch[alone] + half, switch[~alone]])
    fixed = np.concatenate([[0.0, timing.duration], pairs])
    fixed.sort()
    near = np.searchsorted(fixed, base)
    gap = np.minimum(
        np.abs(base - fixed[np.clip(near, 0, len(fixed) - 1)]),
        np.abs(base - fixed[np.clip(near - 1, 0, len(fixed) - 1)]),
    )
    merged = np.union1d(fixed, base[gap >= MIN_SPACING])
    keep = np.concatenate([[True], np.diff(merged) >= 0.99 * MIN_SPACING])
    merged = merged[keep]
    merged[-1] = timing.duration
    if len(merged) > max_points:
        raise TooLarge(
            f"the motion switches acceleration at {len(switch)} times; with the sampling asked "
            f"that is {len(merged)} points, over the limit of {max_points}",
            field=("samples",) if samples is not None else ("sample_period",),
        )
    return merged


def _check_positions(path: JointPath, limits: JointLimits, names: tuple[str, ...]) -> None:
    """``JointLimit`` naming the joint and ``s`` where the path leaves the position limits (a
    spline may overshoot between its waypoints)."""
    if limits.position is None:
        return
    b = np.unique(np.asarray(path.breakpoints(), dtype=float))
    f = np.arange(1, POSITION_CHECKS) / POSITION_CHECKS
    s = np.concatenate([(b[:-1, None] + np.diff(b)[:, None] * f).ravel(), b])
    bad = outside(path(s), limits.position)
    if bad.any():
        k, j = (int(v) for v in np.argwhere(bad)[0])
        frac = float(s[k] / path.length)
        raise JointLimit(
            f"the path takes joint {names[j]} outside its position limits at s={frac:.6g}",
            joint=j,
            s=frac,
        )


def _arc_length(path: JointPath, timing: TimeOptimal | JerkLimited) -> float:
    """Joint-space arc length [rad or m]: Gauss-Legendre (5 points) on every grid interval."""
    s = timing.profile.s
    nodes, weights = np.polynomial.legendre.leggauss(5)
    mid, half = 0.5 * (s[1:] + s[:-1]), 0.5 * np.diff(s)
    at = (mid[:, None] + half[:, None] * nodes).ravel()
    speed = np.linalg.norm(path(at, 1), axis=1).reshape(len(mid), -1)
    return float(np.sum(half * (speed @ weights)))
