"""Deviation of a returned joint trajectory from the Cartesian straight line, measured densely.

The promise of every Cartesian method is about what is returned, not about the samples a planner
looked at. Between two consecutive returned points a controller interpolates: the ROS 2 joint
trajectory controller uses a cubic Hermite spline through positions and velocities, and a simple
client interpolates joints linearly. ``measure_deviation`` checks both at ``checks`` interior points
of every interval (so at least 10 checks between consecutive points by default) and reports the
worse of the two, position [m] and orientation [rad] separately, against the line's closest point.

Below it, Taylor's bounded deviation (``plan_bounded_deviation``, course notes §7.1) and the pieces
it shares with the optimization form in ``core/deviation_nlp.py``: the knot path (a C2 spline in the
path parameter), its timing and sampling, and the split-until-measured-within-tolerance loop.
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from core.budget import NO_DEADLINE, Deadline
from core.errors import (
    BranchFlip,
    Infeasible,
    JointLimit,
    Singularity,
    Unreachable,
)
from core.geometry import so3
from core.kinematics import Kinematics, task_rows
from core.path.base import PathDeviation
from core.path.line import StraightLine
from core.trajectory import Trajectory

if TYPE_CHECKING:
    from core.cartesian_task import CartesianResult, CartesianTask
    from core.line_timing import PathTiming

DEFAULT_CHECKS = 10
"""Interior check points between two consecutive returned points."""


@dataclass(frozen=True)
class DeviationReport:
    """Dense deviation of a trajectory from its line.

    Attributes:
        max_position: Largest position deviation [m] anywhere checked.
        max_orientation: Largest orientation deviation [rad] anywhere checked.
        segment_position: Largest position deviation [m] within each interval, shape ``(N-1,)``.
        segment_orientation: Largest orientation deviation [rad] within each interval, ``(N-1,)``.
        times: Check times [s], shape ``(M,)`` with ``M = (N-1)(checks+1)+1``.
        s: Closest path parameter at each check, ``(M,)``.
        position: Position deviation [m] at each check, ``(M,)``.
        orientation: Orientation deviation [rad] at each check, ``(M,)``.
    """

    max_position: float
    max_orientation: float
    segment_position: np.ndarray
    segment_orientation: np.ndarray
    times: np.ndarray
    s: np.ndarray
    position: np.ndarray
    orientation: np.ndarray


def dense_times(times: np.ndarray, checks: int = DEFAULT_CHECKS) -> np.ndarray:
    """``times`` (N,) with ``checks`` evenly spaced points inserted in every interval: (M,)."""
    times = np.asarray(times, dtype=float)
    frac = np.arange(checks + 1) / (checks + 1)
    inner = times[:-1, None] + frac[None, :] * np.diff(times)[:, None]
    return np.append(inner.ravel(), times[-1])


def interpolate_linear(times: np.ndarray, positions: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Joint positions at ``t`` (M,) by linear interpolation of ``positions`` (N, dof): (M, dof)."""
    idx = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = times[idx + 1] - times[idx]
    a = ((t - times[idx]) / h)[:, None]
    return (1.0 - a) * positions[idx] + a * positions[idx + 1]


def measure_deviation(
    kin: Kinematics,
    line: StraightLine,
    traj: Trajectory,
    checks: int = DEFAULT_CHECKS,
    position_tolerance: float = 1e-3,
    orientation_tolerance: float = 1e-2,
) -> DeviationReport:
    """Measure how far the tool strays from ``line`` along ``traj`` (see the module docstring).

    Args:
        kin: The robot.
        line: The straight line the tool should follow.
        traj: The returned trajectory (at least 2 points).
        checks: Interior checks per interval, >= 1.
        position_tolerance: [m], only weighs position against orientation (see ``StraightLine``).
        orientation_tolerance: [rad], likewise.
    """
    t = dense_times(traj.times, checks)
    q_lin = interpolate_linear(traj.times, traj.positions, t)
    q_herm = CubicHermiteSpline(traj.times, traj.positions, traj.velocities, axis=0)(t)
    devs = [
        line.deviation(kin.fk_many(q), position_tolerance, orientation_tolerance)
        for q in (q_lin, q_herm)
    ]
    worst = 0 if np.max(devs[0].position) >= np.max(devs[1].position) else 1
    position = np.maximum(devs[0].position, devs[1].position)
    orientation = np.maximum(devs[0].orientation, devs[1].orientation)
    n = len(traj.times)
    per = checks + 1
    seg_pos = _segment_max(position, n, per)
    seg_ori = _segment_max(orientation, n, per)
    return DeviationReport(
        max_position=float(position.max()),
        max_orientation=float(orientation.max()),
        segment_position=seg_pos,
        segment_orientation=seg_ori,
        times=t,
        s=devs[worst].s,
        position=position,
        orientation=orientation,
    )


def _segment_max(values: np.ndarray, n: int, per: int) -> np.ndarray:
    """Max over each interval's checks, both end points included: (n-1,)."""
    body = values[:-1].reshape(n - 1, per).max(axis=1)
    return np.maximum(body, values[per::per])


# --- Taylor's bounded deviation (course notes §7.1) ----------------------------------------------
#
# 1. IK continuation along the line from the start (``continuation``: small steps, each solution
#    where the Jacobian predicts it): the goal configuration on the start's branch, and a reference
#    of that branch (the request's goal positions are used when they are on it).
# 2. Knots in joint space (``taylor_knots``); between two knots the arm moves by joint
#    interpolation. The joint midpoint of each segment is tested against the Cartesian midpoint (lerp
#    + slerp 0.5), position and orientation separately, at ``MARGIN`` times the tolerances; a failing
#    segment gets a new knot, IK at the Cartesian midpoint seeded from the joint midpoint (then from
#    the reference), a solution on another branch rejected (``BranchFlip``), and both halves are
#    tested again, down to ``MAX_DEPTH``.
# 3. The returned joint path is the C2 cubic spline q(s) through the knots in the path parameter s
#    (``KnotPath``: a controller cannot follow the corners of joint interpolation at speed). The
#    midpoint is only a heuristic, so the spline is checked densely (``check_knot_path``), timed
#    along s with the timing every Cartesian method shares (``time_knot_path``), and the returned
#    trajectory is measured densely as a client interpolates it (``measured_knots``); every knot
#    segment that still strays is split again, until the returned trajectory is within the
#    tolerance everywhere it is checked. Checks use ``strict_deviation``: the weighted closest point
#    of ``StraightLine.deviation`` and the orientation at the closest point by position alone.
# 4. ``finish`` (limits, the reported measurement); ``plan_partial`` turns a located failure into the
#    plan of the reachable prefix when the client allows it.

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
BRANCH_FACTOR = 3.0
"""A knot IK solution may be at most this many times farther (max-abs, per joint) from its seed than
the Jacobian's least-squares step predicts, plus ``BRANCH_SLACK``; farther is another branch."""
BRANCH_SLACK = 0.05
"""[rad or m] absolute slack of the branch test."""
IK_TOLERANCE = 1e-6
"""Largest IK residual [m] and [rad] of a knot accepted as on the line."""
SINGULAR_VALUE_WARNING = 1e-3
"""A returned path whose task Jacobian's smallest singular value falls below this gets a warning."""
GOAL_BRANCH_TOLERANCE = 0.1
"""[rad] a requested goal configuration is used when it is this close (max-abs) to the one reached by
IK continuation along the line from the start, i.e. on the same branch."""
CONTINUATION_STEP = (0.05, 0.25)
"""Largest step [m], [rad] of tool motion of the IK continuation that finds the goal configuration
on the start's branch."""
CONTINUATION_JOINT_STEP = 0.1
"""Largest predicted joint step [rad] of one continuation step."""
MIN_CONTINUATION_STEP = 1e-5
"""Shortest continuation step [share of s]; a failure there is the line's failure."""
STRICT_BRANCH = (0.5, 1e-3)
"""Continuation steps: the IK solution must be within ``0.5 |predicted step| + 1e-3`` [rad]
(max-abs) of where the Jacobian predicts (the test of the ``sampled`` method)."""
_TIMING_GRID = 2001
_MAX_RETIMES = 4


@dataclass(frozen=True)
class Knots:
    """Knots of a bounded-deviation plan.

    Attributes:
        s: Path parameter of each knot, increasing from 0 to 1, shape ``(K,)``.
        positions: Joint positions of each knot, ``(K, dof)``.
    """

    s: np.ndarray
    positions: np.ndarray

    def __len__(self) -> int:
        return len(self.s)

    def insert(self, s: np.ndarray, positions: np.ndarray) -> Knots:
        """These knots plus new ones (path parameters ``s`` (n,), joints ``(n, dof)``), sorted."""
        all_s = np.concatenate([self.s, s])
        order = np.argsort(all_s, kind="stable")
        return Knots(all_s[order], np.vstack([self.positions, positions])[order])


class KnotPath:
    """The joint path through knots: q(s), a C2 cubic spline in s (not-a-knot; a line for 2 knots).

    Args:
        knots: The knots; ``s`` strictly increasing from 0 to 1.
    """

    def __init__(self, knots: Knots) -> None:
        self.knots = knots
        self._spline = CubicSpline(knots.s, knots.positions, axis=0, bc_type="not-a-knot")

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q (order 0), dq/ds (1) or d2q/ds2 (2) at path parameters ``s`` (N,): (N, dof)."""
        return self._spline(np.clip(np.asarray(s, dtype=float), 0.0, 1.0), order)

    def segment_of(self, s: np.ndarray) -> np.ndarray:
        """Index of the knot segment holding each path parameter in ``s`` (N,)."""
        k = np.searchsorted(self.knots.s, s, side="right") - 1
        return np.clip(k, 0, len(self.knots) - 2)


def task_error(task_space: str, T_a: np.ndarray, T_b: np.ndarray) -> tuple[float, float]:
    """Position [m] and orientation [rad] difference of two poses (4, 4), task components only."""
    rows = 2 if task_space == "position_xy" else 3
    position = float(np.linalg.norm(T_a[:rows, 3] - T_b[:rows, 3]))
    if task_space == "position_xy":
        return position, 0.0
    return position, float(so3.rotation_angle(T_a[:3, :3].T @ T_b[:3, :3]))


def predicted_step(kin: Kinematics, q: np.ndarray, T_target: np.ndarray) -> np.ndarray:
    """Least-squares joint step (dof,) the Jacobian at ``q`` predicts toward the pose ``T_target``."""
    T = kin.fk(q)
    twist = np.zeros(6)
    twist[:3] = T_target[:3, 3] - T[:3, 3]
    twist[3:] = so3.log(T_target[:3, :3] @ T[:3, :3].T)
    rows = task_rows(kin.task_space)
    step, *_ = np.linalg.lstsq(kin.jacobian(q)[rows], twist[rows], rcond=1e-6)
    return step


def same_branch(step: np.ndarray, predicted: np.ndarray) -> bool:
    """Whether a joint ``step`` (dof,) is within what the Jacobian's ``predicted`` step allows."""
    limit = BRANCH_FACTOR * float(np.max(np.abs(predicted))) + BRANCH_SLACK
    return float(np.max(np.abs(step))) <= limit


def _can_roam(kin: Kinematics) -> bool:
    try:
        return "respect_limits" in inspect.signature(kin.ik).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False


def solve_on_line(
    kin: Kinematics,
    line: StraightLine,
    s: float,
    seed: np.ndarray,
    reference: np.ndarray | None = None,
    *,
    strict: bool = False,
) -> np.ndarray:
    """Joint positions (dof,) at the line's pose at ``s``, on the branch of ``seed``.

    IK from ``seed``, then from the seed moved by the Jacobian's predicted step, then from
    ``reference`` (a configuration on the start's branch near ``s``, from ``continuation``). A
    solution is on the branch when its distance to the seed, or to the reference, is within what the
    Jacobian predicts (``same_branch``); ``strict`` (small steps): when it is within
    ``STRICT_BRANCH`` of the predicted configuration. Raises ``BranchFlip`` when IK converges only on
    another branch, ``JointLimit`` when only outside the joint limits, ``Unreachable`` when not at
    all; each with ``s``.
    """
    T = line.pose(s)
    seed = np.asarray(seed, dtype=float)
    anchors = [(seed, predicted_step(kin, seed, T))]
    starts = [seed + anchors[0][1], seed] if strict else [seed, seed + anchors[0][1]]
    if reference is not None:
        anchors.append((reference, predicted_step(kin, reference, T)))
        starts.append(reference)
    outcome = "unreachable"
    # IK may roam outside the limits when the robot allows it, so a solution reachable only outside
    # them is told apart (joint_limit) from no solution at all (unreachable).
    options = {"respect_limits": False} if _can_roam(kin) else {}
    for start in starts:
        res = kin.ik(T, start, position_tolerance=1e-9, orientation_tolerance=1e-9, **options)
        converged = res.position_error <= IK_TOLERANCE and res.orientation_error <= IK_TOLERANCE
        if not converged:
            continue
        if not res.within_limits:
            outcome = "joint_limit" if outcome == "unreachable" else outcome
            continue
        q = np.asarray(res.positions, dtype=float)
        if strict:
            predicted = anchors[0][1]
            off = float(np.max(np.abs(q - seed - predicted)))
            if off <= STRICT_BRANCH[0] * float(np.max(np.abs(predicted))) + STRICT_BRANCH[1]:
                return q
        elif any(same_branch(q - anchor, predicted) for anchor, predicted in anchors):
            return q
        outcome = "branch_flip"
    where = f"at s={s:.4g}"
    if outcome == "branch_flip":
        raise BranchFlip(f"IK on the line {where} lands only on another branch", s=float(s))
    if outcome == "joint_limit":
        raise JointLimit(f"the line {where} is reachable only outside the joint limits", s=float(s))
    raise Unreachable(f"no IK solution within {IK_TOLERANCE:g} m on the line {where}", s=float(s))


def continuation(
    kin: Kinematics, line: StraightLine, q_start: np.ndarray, deadline: Deadline = NO_DEADLINE
) -> Knots:
    """IK along the line from ``q_start``, each point seeded where the Jacobian predicts the arm
    will be and checked to be there (``strict`` branch test): the start's branch.

    Steps of at most ``CONTINUATION_STEP`` of tool motion, 1/256 of the line, and
    ``CONTINUATION_JOINT_STEP`` of predicted joint motion (short steps where joints move fast, near
    singularities), halved down to ``MIN_CONTINUATION_STEP`` where a step fails; the failure there is
    raised with ``extra["s_reached"]``.
    """
    steps = int(np.ceil(max(line.length / CONTINUATION_STEP[0], line.angle / CONTINUATION_STEP[1])))
    ds_max = 1.0 / min(max(steps, 1), 256)
    rows = task_rows(kin.task_space)
    twist = line.derivative(np.zeros(1))[0][rows]  # tool twist per unit s (a line: constant)
    s, q = 0.0, np.asarray(q_start, dtype=float)
    s_list, q_list = [s], [q]
    halved = 1.0
    while s < 1.0:
        deadline.check("bounded deviation: IK continuation")
        dq_ds, *_ = np.linalg.lstsq(kin.jacobian(q)[rows], twist, rcond=1e-6)
        rate = float(np.max(np.abs(dq_ds)))
        ds = min(ds_max, CONTINUATION_JOINT_STEP / rate if rate > 0 else ds_max) * halved
        ds = max(ds, MIN_CONTINUATION_STEP)
        s_next = min(1.0, s + ds)
        try:
            q = solve_on_line(kin, line, s_next, q, strict=True)
        except (BranchFlip, Unreachable, JointLimit) as err:
            if ds <= MIN_CONTINUATION_STEP:
                err.extra["s_reached"] = s
                raise
            halved *= 0.5
            continue
        s, halved = s_next, min(1.0, 2.0 * halved)
        s_list.append(s)
        q_list.append(q)
    return Knots(np.array(s_list), np.array(q_list))


def reference_at(reference: Knots | None, s: float) -> np.ndarray | None:
    """The continuation's configuration at ``s`` (linear between its points), or None."""
    if reference is None:
        return None
    return np.array([np.interp(s, reference.s, col) for col in reference.positions.T])


def goal_configuration(
    kin: Kinematics,
    line: StraightLine,
    q_start: np.ndarray,
    q_hint: np.ndarray | None = None,
    deadline: Deadline = NO_DEADLINE,
) -> tuple[np.ndarray, list[str], Knots]:
    """The goal's joint positions on the start's branch, warnings, and the continuation.

    The end of ``continuation``; ``q_hint`` (the request's goal positions) is used instead when it
    lies within ``GOAL_BRANCH_TOLERANCE`` of it, otherwise a warning says so.
    """
    reference = continuation(kin, line, q_start, deadline)
    q = reference.positions[-1]
    if q_hint is not None:
        q_hint = np.asarray(q_hint, dtype=float)
        gap = float(np.max(np.abs(q_hint - q)))
        if gap <= GOAL_BRANCH_TOLERANCE:
            return q_hint, [], reference
        return (
            q,
            [
                f"the line ends at the goal pose in another joint configuration than goal.positions "
                f"(up to {gap:.3g} rad apart): the trajectory ends where the line leads, without a "
                "branch flip"
            ],
            reference,
        )
    return q, [], reference


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


def taylor_knots(
    kin: Kinematics,
    line: StraightLine,
    q_start: np.ndarray,
    q_goal: np.ndarray,
    position_tolerance: float,
    orientation_tolerance: float,
    *,
    max_depth: int = MAX_DEPTH,
    deadline: Deadline = NO_DEADLINE,
    stats: TaylorStats | None = None,
    reference: Knots | None = None,
) -> Knots:
    """Taylor's recursive midpoint method: knots from ``q_start`` (s=0) to ``q_goal`` (s=1).

    A segment is kept when FK of its joint midpoint is within ``MARGIN`` times the tolerances [m],
    [rad] of the Cartesian midpoint; otherwise it is halved at a knot solved by ``solve_on_line`` from
    the joint midpoint (``reference``, the continuation, gives the branch when the joint midpoint is
    far from it). Past ``max_depth`` halvings (or ``MAX_KNOTS`` knots) ``Infeasible`` is raised
    with the ``s`` of the segment.
    """
    stats = TaylorStats() if stats is None else stats
    tol_p, tol_o = MARGIN * position_tolerance, MARGIN * orientation_tolerance
    found: list[tuple[float, np.ndarray]] = []

    def split(sa: float, qa: np.ndarray, sb: float, qb: np.ndarray, depth: int) -> None:
        deadline.check("bounded deviation")
        stats.midpoint_tests += 1
        stats.max_depth = max(stats.max_depth, depth)
        s_mid, q_mid = 0.5 * (sa + sb), 0.5 * (qa + qb)
        T_mid = line.pose(s_mid)
        err_p, err_o = task_error(kin.task_space, kin.fk(q_mid), T_mid)
        if err_p <= tol_p and err_o <= tol_o:
            return
        if depth >= max_depth or len(found) + 2 >= MAX_KNOTS:
            raise Infeasible(
                f"the deviation stays above the tolerance near s={s_mid:.4g} after {depth} "
                f"halvings of the line (limit {max_depth}, {MAX_KNOTS} knots)",
                s=s_mid,
                extra={"depth": depth},
            )
        q_new = solve_on_line(kin, line, s_mid, q_mid, reference_at(reference, s_mid))
        stats.ik_calls += 1
        split(sa, qa, s_mid, q_new, depth + 1)
        found.append((s_mid, q_new))
        split(s_mid, q_new, sb, qb, depth + 1)

    q_start, q_goal = np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float)
    split(0.0, q_start, 1.0, q_goal, 0)
    s = np.array([0.0, *(f[0] for f in found), 1.0])
    positions = np.vstack([q_start, *(f[1] for f in found), q_goal])
    return Knots(s, positions)


def strict_deviation(
    kin: Kinematics, line: StraightLine, q: np.ndarray, tol_p: float, tol_o: float
) -> PathDeviation:
    """Deviation of configurations ``q`` (N, dof) from the line (``StraightLine.deviation``, whose
    orientation term already takes the larger of the two closest-point readings a client may use)."""
    return line.deviation(kin.fk_many(q), tol_p, tol_o)


def path_deviation(
    kin: Kinematics, line: StraightLine, path: KnotPath, s: np.ndarray, tol_p: float, tol_o: float
) -> PathDeviation:
    """Deviation (``strict_deviation``) of the knot path at path parameters ``s`` (N,)."""
    return strict_deviation(kin, line, path(s), tol_p, tol_o)


def split_segments(
    kin: Kinematics,
    line: StraightLine,
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
    q_new = np.array(
        [
            solve_on_line(kin, line, s, q, reference_at(reference, s))
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
    line: StraightLine,
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
    lo, hi = kin.position_limits[:, 0], kin.position_limits[:, 1]
    for round_ in range(MAX_RESPLIT_ROUNDS + 1):
        deadline.check("bounded deviation: path check")
        path = KnotPath(knots)
        s = dense_times(knots.s, checks)
        dev = path_deviation(kin, line, path, s, position_tolerance, orientation_tolerance)
        q = path(s)
        bad = (
            (dev.position > MARGIN * position_tolerance)
            | (dev.orientation > MARGIN * orientation_tolerance)
            | np.any((q < lo) | (q > hi), axis=1)
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
        timing: s(t) and its warnings (``core.line_timing.PathTiming``).
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


def time_knot_path(task: CartesianTask, line: StraightLine, path: KnotPath) -> TimedPath:
    """Time ``path`` along s and sample it, with the timing every Cartesian method shares
    (``core.line_timing``: a given duration, else the tool speed limits and the joint velocity and
    acceleration limits on a grid of ``_TIMING_GRID`` points plus the knots). The samples start at
    the first knot and end exactly at the last one, at rest."""
    from core.line_timing import sample_path, time_path, timed_trajectory  # imports cartesian_task

    vmax = task.robot.velocity_limits * (1.0 + 1e-9)
    grid = np.union1d(np.linspace(0.0, 1.0, _TIMING_GRID), path.knots.s)
    for _ in range(_MAX_RETIMES):
        timing = time_path(task, line, grid, path(grid, 1), path(grid, 2))
        times, s = sample_path(task, timing)
        positions = path(s)
        positions[0], positions[-1] = path.knots.positions[0], path.knots.positions[-1]
        traj = timed_trajectory(
            times, timing, positions, path(s, 1), path(s, 2), tuple(task.robot.joint_names)
        )
        over = np.any(np.abs(traj.velocities) > vmax, axis=1)
        if not over.any():
            break
        # A returned point between grid points needs its own cap: add it to the grid, re-time.
        grid = np.union1d(grid, s[over])
    return TimedPath(path, timing, traj, s)


MEASURE_CHUNK = 2048
"""Returned intervals measured between two deadline checks."""


def interval_excess(
    kin: Kinematics,
    line: StraightLine,
    traj: Trajectory,
    tol_p: float,
    tol_o: float,
    deadline: Deadline = NO_DEADLINE,
) -> np.ndarray:
    """Largest deviation over the tolerance (1.0: at the bound) in each interval of ``traj``,
    ``(N-1,)``: as ``measure_deviation`` (joints interpolated linearly and by cubic Hermite at
    ``DEFAULT_CHECKS`` points in each interval), with ``strict_deviation``, ``MEASURE_CHUNK``
    intervals at a time with ``deadline`` checked between them."""
    n, per = len(traj.times), DEFAULT_CHECKS + 1
    out = []
    for i in range(0, n - 1, MEASURE_CHUNK):
        deadline.check("bounded deviation: dense measurement")
        j = min(i + MEASURE_CHUNK, n - 1) + 1
        times, positions = traj.times[i:j], traj.positions[i:j]
        t = dense_times(times, DEFAULT_CHECKS)
        excess = np.zeros(len(t))
        for q in (
            interpolate_linear(times, positions, t),
            CubicHermiteSpline(times, positions, traj.velocities[i:j], axis=0)(t),
        ):
            dev = strict_deviation(kin, line, q, tol_p, tol_o)
            excess = np.maximum(excess, np.maximum(dev.position / tol_p, dev.orientation / tol_o))
        out.append(_segment_max(excess, j - i, per))
    return np.concatenate(out)


def measured_knots(
    task: CartesianTask,
    line: StraightLine,
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
    line: StraightLine,
    knots: Knots,
    *,
    stats: TaylorStats,
    diagnostics: dict[str, Any],
    warnings: list[str],
    reference: Knots | None = None,
) -> CartesianResult:
    """``measured_knots``, then ``finish`` the result (limits, measurement, smallest singular
    value) with the knots and diagnostics."""
    from core.cartesian_task import CartesianResult, finish  # cartesian_task imports this module

    knots, timed = measured_knots(task, line, knots, stats=stats, reference=reference)
    knot_times = timed.knot_times()
    result = CartesianResult(
        trajectory=timed.trajectory,
        warnings=[*warnings, *timed.timing.warnings],
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
    if result.min_singular_value < SINGULAR_VALUE_WARNING:
        result.warnings.append(
            f"the path passes near a singular configuration (smallest singular value "
            f"{result.min_singular_value:.3g}); joint rates stay within their limits"
        )
    return result


def plan_bounded_deviation(task: CartesianTask) -> CartesianResult:
    """Taylor's bounded deviation: knots by the recursive midpoint test, a C2 spline through them,
    split again wherever the returned trajectory strays (see the section comment above).

    Raises ``InputError`` / ``JointLimit`` (entry checks), ``Unreachable`` / ``JointLimit`` /
    ``BranchFlip`` (a knot's IK, with ``s``), ``Infeasible`` (depth, knot or splitting limits),
    ``JointRateLimit`` (a fixed duration too short), ``Singularity`` (joint rates),
    ``TimeBudgetExceeded`` (``task.deadline``). With ``task.allow_partial`` a failure located at
    ``s`` gives the plan of the reachable prefix instead (``plan_partial``).
    """
    return plan_partial(task, _plan_taylor)


def _plan_taylor(task: CartesianTask) -> CartesianResult:
    from core.cartesian_task import validated_line  # cartesian_task imports this module

    line = validated_line(task)
    started = time.perf_counter()
    stats = TaylorStats()
    q_goal, warnings, reference = goal_configuration(
        task.robot, line, task.q_start, task.q_goal, task.deadline
    )
    knots = taylor_knots(
        task.robot,
        line,
        task.q_start,
        q_goal,
        task.position_tolerance,
        task.orientation_tolerance,
        deadline=task.deadline,
        stats=stats,
        reference=reference,
    )
    taylor_count = len(knots)
    knots = check_knot_path(
        task.robot,
        line,
        knots,
        task.position_tolerance,
        task.orientation_tolerance,
        deadline=task.deadline,
        stats=stats,
        reference=reference,
    )
    diagnostics = {
        "midpoint_knot_count": taylor_count,
        "knot_time_ms": 1e3 * (time.perf_counter() - started),
    }
    return finish_knots(
        task,
        line,
        knots,
        stats=stats,
        diagnostics=diagnostics,
        warnings=warnings,
        reference=reference,
    )


MIN_FRACTION = 1e-3
"""Shortest prefix [share of s] a partial plan may return."""
_PARTIAL_TRIES = 3


def plan_partial(
    task: CartesianTask, plan: Callable[[CartesianTask], CartesianResult]
) -> CartesianResult:
    """``plan(task)``; with ``task.allow_partial``, a failure at ``s`` (unreachable, joint limit,
    branch flip, singularity) gives ``plan`` of the prefix of the line up to where it was last
    reached (``extra["s_reached"]``, else just before ``s``): ``fraction`` < 1, ``failure`` set, the
    knots' ``s`` on the whole line."""
    try:
        return plan(task)
    except (Unreachable, JointLimit, BranchFlip, Singularity) as err:
        if not task.allow_partial or err.s is None or err.field is not None:
            raise
        failure = err
    line = task.line()
    fail_at, reached = float(failure.s), failure.extra.get("s_reached")
    for _ in range(_PARTIAL_TRIES):
        end = float(reached) if reached is not None else 0.95 * fail_at
        if end < MIN_FRACTION:
            raise failure
        prefix = replace(task, T_goal=line.pose(end), q_goal=None, allow_partial=False)
        try:
            result = plan(prefix)
            break
        except (Unreachable, JointLimit, BranchFlip, Singularity) as err:
            if err.s is None:
                raise
            # The prefix's own s runs over [0, 1]: on the whole line it is end * s.
            fail_at = end * float(err.s)
            reached = end * float(err.extra["s_reached"]) if "s_reached" in err.extra else None
    else:
        raise failure
    result.fraction = end
    result.failure = failure
    result.warnings.insert(0, f"planned {end:.1%} of the line: {failure.detail}")
    if result.knots is not None:
        result.knots["s"] = result.knots["s"] * end
    return result
