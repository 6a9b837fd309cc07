"""Taylor's knot machinery shared by both bounded-deviation methods (course notes sec. 7.1).

1. IK continuation along the line from the start (``continuation``: small steps, each solution
   where the Jacobian predicts it): the goal configuration on the start's branch, and a reference
   of that branch (the request's goal positions are used when they are on it).
2. Knots in joint space (``taylor_knots``); between two knots the arm moves by joint
   interpolation. The joint midpoint of each segment is tested against the Cartesian midpoint (lerp
   + slerp 0.5), position and orientation separately, at ``MARGIN`` times the tolerances; a failing
   segment gets a new knot, IK at the Cartesian midpoint seeded from the joint midpoint (then from
   the reference), a solution on another branch rejected (``BranchFlip``), and both halves are
   tested again, down to ``MAX_DEPTH``.
3. The returned joint path is the C2 cubic spline q(s) through the knots in the path parameter s
   (``KnotPath``: a controller cannot follow the corners of joint interpolation at speed). The
   midpoint is only a heuristic, so the spline is checked densely (``check_knot_path``), timed
   along s with the timing every Cartesian method shares (``time_knot_path``), and the returned
   trajectory is measured densely as a client interpolates it (``measured_knots``); every knot
   segment that still strays is split again, until the returned trajectory is within the
   tolerance everywhere it is checked. Checks use ``strict_deviation``: the weighted closest point
   of ``StraightLine.deviation`` and the orientation at the closest point by position alone.
4. ``finish`` (limits, the reported measurement); ``plan_partial`` turns a located failure into the
   plan of the reachable prefix when the client allows it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.check import finish
from core.cartesian.ik_on_path import reference_at, solve_on_line
from core.cartesian.knot_path import KnotPath, Knots
from core.cartesian.measure import DEFAULT_CHECKS, dense_times, interval_excess, strict_deviation
from core.cartesian.task import CartesianResult, CartesianTask
from core.cartesian.timing import PathTiming, sample_path, time_path, timed_trajectory
from core.errors import (
    Infeasible,
)
from core.kinematics import SINGULAR_VALUE_THRESHOLD, Kinematics, jacobians, task_rows
from core.limits import inside, over_speed
from core.path.base import Path, PathDeviation
from core.trajectory import Trajectory

MARGIN = 0.9
"""Share of each tolerance the planners aim at (midpoint test, path checks, the NLP's constraints);
the rest absorbs interpolation between returned samples."""
MAX_DEPTH = 12
"""Deepest halving of the line by the midpoint test (segments down to 1/4096 of it)."""
MAX_KNOTS = 4097
"""Most knots a bounded-deviation plan may hold (a full binary split to ``MAX_DEPTH``)."""
MAX_RESPLIT_ROUNDS = 8
"""Rounds of splitting after a dense check (of the knot path or of the returned trajectory)."""
PATH_CHECKS = 16
"""Interior checks per knot segment when the knot path itself is checked before timing."""


"""A returned path whose task Jacobian's smallest singular value falls below this gets a warning."""


_TIMING_GRID = 2001
_MAX_RETIMES = 4


@dataclass
class TaylorStats:
    """Counters of one bounded-deviation plan (reported in the diagnostics).

    Attributes:
        midpoint_tests: Joint midpoints tested against the Cartesian midpoint.
        max_depth: Deepest recursion level reached (0: the whole line).
        ik_calls: Knots solved by IK on the line.
        path_splits: Knot segments split because the knot path strayed between knots.
        resplits: Knot segments split because the returned trajectory strayed.
    """

    midpoint_tests: int = 0
    max_depth: int = 0
    ik_calls: int = 0
    path_splits: int = 0
    resplits: int = 0


def path_deviation(
    kin: Kinematics, line: Path, path: KnotPath, s: np.ndarray, tol_p: float, tol_o: float
) -> PathDeviation:
    """Deviation (``strict_deviation``) of the knot path at path parameters ``s`` (N,)."""
    return strict_deviation(kin, line, path(s), tol_p, tol_o)


def split_segments(
    kin: Kinematics,
    line: Path,
    knots: Knots,
    segments: np.ndarray,
    stats: TaylorStats | None = None,
    reference: Knots | None = None,
) -> Knots:
    """``knots`` with a new on-line knot in the middle (in s) of each listed knot segment, solved
    from the knot path there (and ``reference``, the continuation)."""
    path = KnotPath(knots)
    s_new = 0.5 * (knots.s[segments] + knots.s[segments + 1])
    seeds = path(s_new)
    label = kin.configuration(knots.positions[0])  # the start's
    q_new = np.array(
        [
            solve_on_line(kin, line, s, q, reference_at(reference, s), label=label)
            for s, q in zip(s_new, seeds, strict=True)
        ]
    )
    if stats is not None:
        stats.ik_calls += len(s_new)
    if len(knots) + len(s_new) > MAX_KNOTS:
        raise Infeasible(
            f"bounding the deviation needs more than {MAX_KNOTS} knots",
            s=float(s_new[0]),
        )
    return knots.insert(s_new, q_new)


def check_knot_path(
    kin: Kinematics,
    line: Path,
    knots: Knots,
    position_tolerance: float,
    orientation_tolerance: float,
    *,
    checks: int = PATH_CHECKS,
    deadline: Deadline = NO_DEADLINE,
    stats: TaylorStats | None = None,
    reference: Knots | None = None,
) -> Knots:
    """Split knot segments until the spline through the knots stays within ``MARGIN`` times the
    tolerances at ``checks`` interior points of every segment and inside the joint limits."""
    stats = TaylorStats() if stats is None else stats
    for round_ in range(MAX_RESPLIT_ROUNDS + 1):
        deadline.check("bounded deviation: path check")
        path = KnotPath(knots)
        s = dense_times(knots.s, checks)
        dev = path_deviation(kin, line, path, s, position_tolerance, orientation_tolerance)
        q = path(s)
        bad = (
            (dev.position > MARGIN * position_tolerance)
            | (dev.orientation > MARGIN * orientation_tolerance)
            | ~inside(q, kin.position_limits)
        )
        if not bad.any():
            return knots
        if round_ == MAX_RESPLIT_ROUNDS:
            break
        segments = np.unique(path.segment_of(s[bad]))
        stats.path_splits += len(segments)
        knots = split_segments(kin, line, knots, segments, stats, reference)
    raise Infeasible(
        f"the knot path still strays from the line after {MAX_RESPLIT_ROUNDS} rounds of splitting",
        s=float(s[bad][0]),
    )


@dataclass(frozen=True)
class TimedPath:
    """A knot path timed along s and sampled.

    Attributes:
        path: The joint path q(s).
        timing: s(t) and its warnings (``core.cartesian.timing.PathTiming``).
        trajectory: The samples returned to the client.
        s: Path parameter of each sample, ``(N,)``.
    """

    path: KnotPath
    timing: PathTiming
    trajectory: Trajectory
    s: np.ndarray

    def s_at(self, t: np.ndarray) -> np.ndarray:
        """Path parameter at times ``t`` [s]."""
        return np.asarray(self.timing.profile(t), dtype=float)

    def knot_times(self) -> np.ndarray:
        """Time [s] at which the trajectory passes each knot, ``(K,)``."""
        t = np.asarray(self.timing.profile.time_at(self.path.knots.s), dtype=float)
        t[0], t[-1] = 0.0, self.timing.duration
        return t


def tool_rates(robot: Kinematics, q: np.ndarray, dq_ds: np.ndarray) -> np.ndarray:
    """The tool's linear [m] and angular [rad] rates per unit s, ``(N, 2)``, of a joint path at
    ``q`` (N, dof) with derivative ``dq_ds`` (N, dof): the norms of J dq/ds over the task's
    linear and angular rows (a knot spline is not exactly on the line, so its tool moves at its
    own rate, not the line's length per unit s)."""
    v = np.einsum("nij,nj->ni", jacobians(robot, q), dq_ds)
    rows = task_rows(robot.task_space)
    linear = np.linalg.norm(v[:, [r for r in rows if r < 3]], axis=1)
    angular = (
        np.linalg.norm(v[:, [r for r in rows if r >= 3]], axis=1) if len(rows) > 3 else 0 * linear
    )
    return np.column_stack([linear, angular])


def time_knot_path(task: CartesianTask, line: Path, path: KnotPath) -> TimedPath:
    """Time ``path`` along s and sample it, with the timing every Cartesian method shares
    (``core.cartesian.timing``: a given duration, else the tool speed limits and the joint velocity and
    acceleration limits on a grid of ``_TIMING_GRID`` points plus the knots). The samples start at
    the first knot and end exactly at the last one, at rest."""

    grid = np.union1d(np.linspace(0.0, 1.0, _TIMING_GRID), path.knots.s)
    for _ in range(_MAX_RETIMES):
        rates = (
            None if task.duration is not None else tool_rates(task.robot, path(grid), path(grid, 1))
        )
        timing = time_path(task, line, grid, path(grid, 1), path(grid, 2), rates)
        times, s = sample_path(task, timing)
        positions = path(s)
        positions[0], positions[-1] = path.knots.positions[0], path.knots.positions[-1]
        traj = timed_trajectory(
            times, timing, positions, path(s, 1), path(s, 2), tuple(task.robot.joint_names)
        )
        over = over_speed(traj.velocities, task.robot.velocity_limits).any(axis=1)
        if not over.any():
            break
        # A returned point between grid points needs its own cap: add it to the grid, re-time.
        grid = np.union1d(grid, s[over])
    return TimedPath(path, timing, traj, s)


def measured_knots(
    task: CartesianTask,
    line: Path,
    knots: Knots,
    *,
    stats: TaylorStats,
    reference: Knots | None = None,
) -> tuple[Knots, TimedPath]:
    """Time the knot path, measure the returned trajectory densely (as ``measure_deviation``: both
    linear and cubic Hermite interpolation between the samples, ``DEFAULT_CHECKS`` points in each
    interval; with ``strict_deviation``), split the knot segments where it strays, repeat until it
    is within the tolerances.

    ``Infeasible`` when the path is within the tolerance but the returned samples are too far apart
    for interpolation between them to stay within it, or after ``MAX_RESPLIT_ROUNDS`` rounds.
    """
    kin, tol_p, tol_o = task.robot, task.position_tolerance, task.orientation_tolerance
    frac = np.arange(DEFAULT_CHECKS + 2) / (DEFAULT_CHECKS + 1)
    for round_ in range(MAX_RESPLIT_ROUNDS + 1):
        task.deadline.check("bounded deviation: dense measurement")
        timed = time_knot_path(task, line, KnotPath(knots))
        traj = timed.trajectory
        excess = interval_excess(kin, line, traj, tol_p, tol_o, task.deadline)
        bad = np.flatnonzero(excess > 1.0)
        if bad.size == 0:
            return knots, timed
        dt = np.diff(traj.times)[bad]
        s = timed.s_at((traj.times[bad][:, None] + frac[None, :] * dt[:, None]).ravel())
        dev = path_deviation(kin, line, timed.path, s, tol_p, tol_o)
        where = float(s[np.argmax(dev.position / tol_p + dev.orientation / tol_o)])
        if max(dev.position.max() / tol_p, dev.orientation.max() / tol_o) <= 0.5:
            raise Infeasible(
                "the path is within the tolerance but the returned points are too far apart: "
                "interpolation between them strays; use a shorter sample_period or more samples",
                s=where,
                extra={"deviation_over_tolerance": float(excess.max())},
            )
        if round_ == MAX_RESPLIT_ROUNDS:
            break
        segments = np.unique(timed.path.segment_of(s))
        stats.resplits += len(segments)
        knots = split_segments(kin, line, knots, segments, stats, reference)
    raise Infeasible(
        f"the trajectory still strays from the line after {MAX_RESPLIT_ROUNDS} rounds of splitting",
        s=where,
    )


def finish_knots(
    task: CartesianTask,
    line: Path,
    knots: Knots,
    *,
    stats: TaylorStats,
    diagnostics: dict[str, Any],
    warnings: list[str],
    reference: Knots | None = None,
) -> CartesianResult:
    """``measured_knots``, then ``finish`` the result (limits, measurement, smallest singular
    value) with the knots and diagnostics."""
    knots, timed = measured_knots(task, line, knots, stats=stats, reference=reference)
    knot_times = timed.knot_times()
    result = CartesianResult(
        trajectory=timed.trajectory,
        warnings=(*warnings, *timed.timing.warnings),
        knots={"s": knots.s.copy(), "times": knot_times, "positions": knots.positions.copy()},
        diagnostics={
            **diagnostics,
            "knot_count": len(knots),
            "midpoint_tests": stats.midpoint_tests,
            "max_recursion_depth": stats.max_depth,
            "ik_calls": stats.ik_calls,
            "path_splits": stats.path_splits,
            "resplits": stats.resplits,
        },
    )
    result = finish(task, result, timed.s)
    if result.min_singular_value < SINGULAR_VALUE_THRESHOLD:
        near = (
            f"the path passes near a singular configuration (smallest singular value "
            f"{result.min_singular_value:.3g}); joint rates stay within their limits"
        )
        result = replace(result, warnings=(*result.warnings, near))
    return result
