"""Collision-free joint motion: direct segment -> sample -> shorten -> smooth -> blend -> time.

``find_path`` is the geometric part (what a motion program's PTP segment with
``planner: "collision_free"`` needs): from a clear start to the first of some clear goals, a
certified path (``core.motion.certify``: no contact between checked configurations). The straight
joint segment to a goal is tried first (``planner.name == "direct"``); else the sampler
(``core.motion.sampler``: OMPL's RRT-Connect, its tree edges certified) searches for
``time_limit`` seconds, its path is shortened (``core.motion.shorten``) and smoothed
(``core.motion.smooth``), each result certified. The corners are then rounded by circular blends
(``core.joint.blended_path.BlendedPath``), each blend certified by its corner's margins (``blend``).

``plan_motion`` is the whole request: start and goals checked before any search (``Collision`` at
``start`` or ``goal`` with the pair; a goal pose whose IK solutions all collide is
``Unreachable``), ``find_path``, then timing (``core.motion.timing``: ``time_optimal`` along the
blended path, ``jerk_limited`` as S-curves along the certified segments, stopping at each knot)
and sampling. No path within the time limit is ``NoPathFound`` with the planner's figures.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.clearance import Clearance
from core.collisions import ClearanceReport, End, check_ends, checked, end_collision
from core.errors import InputError, NoPathFound
from core.joint.blended_path import BlendedPath
from core.joint.effort import held_motion
from core.kinematics import Dynamics
from core.limits import JointLimits
from core.motion.certify import Certifier
from core.motion.clearance import GroupClearance
from core.motion.goals import Goals, clear_goals
from core.motion.repair import SEARCH_MARGIN, SEARCH_RESOLUTION, Repair, reduced
from core.motion.sample import certified_samples, stop_and_go_samples
from core.motion.sampler import RRTConnect, Sampler, SearchProblem
from core.motion.shorten import path_length, shorten
from core.motion.smooth import smooth
from core.motion.timing import TIMINGS
from core.timing.path_constraints import Effort, PathLimits
from core.trajectory import MAX_POINTS, Trajectory

DEFAULT_SAMPLER: Sampler = RRTConnect()
"""The sampling planner."""
SEARCH_EDGE = 0.5
"""[rad] Longest tree edge of the search (measured on the MBM Panda problems: OMPL's default, a
fifth of the joint box's diagonal, 2.6 rad for the Panda, took 8x longer on the cage problems)."""
MAX_ATTEMPTS = 8
"""Lazy searches tried (seeds derived from the request's) before the time runs out."""
MAX_STATES = 100_000
"""Most search-tree states of one request (bounds its memory: ~100 B per state and its margins)."""
BLEND_DEVIATION = 0.1
"""[rad] Largest distance of a blend from its corner (joint space)."""
MIN_REACH = 1e-6
"""[rad] A corner whose certified blend would reach less than this along its segments stays sharp
(the motion stops there)."""


@dataclass(frozen=True)
class PlannerReport:
    """How the path was found: ``name`` ("direct" or the sampler's), ``seed``, ``iterations``
    (segments the search certified or refused), ``states`` (search-tree size), and the wall times
    [ms] of the search, the shortening and the smoothing."""

    name: str
    seed: int
    iterations: int
    states: int
    plan_time_ms: float
    simplify_time_ms: float
    smooth_time_ms: float

    def as_dict(self) -> dict[str, object]:
        return asdict(self)


@dataclass(frozen=True)
class GeometricPath:
    """A certified path.

    Attributes:
        knots: ``(K, dof)``: certified straight segments from the start to the goal reached.
        shortened: ``(K', dof)``: the shortened path before smoothing (certified).
        path: The knots with certified circular blends (a ``JointPath``).
        goal: Index of the goal reached among those given.
        planner: How it was found.
    """

    knots: np.ndarray
    shortened: np.ndarray
    path: BlendedPath
    goal: int
    planner: PlannerReport


def find_path(
    clearance: GroupClearance,
    q_start: np.ndarray,
    goals: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    *,
    seed: int = 0,
    time_limit: float = 5.0,
    sampler: Sampler = DEFAULT_SAMPLER,
    deadline: Deadline = NO_DEADLINE,
) -> GeometricPath:
    """A certified collision-free path from ``q_start`` ``(dof,)`` to one of ``goals`` ``(k, dof)``
    (the first one the direct segment reaches, else the one the search reaches), within the joint
    limits ``lower``, ``upper``. Start and goals must be clear. ``time_limit`` [s] bounds the
    search; ``NoPathFound`` when it finds nothing."""
    started = time.perf_counter()
    certifier = Certifier(clearance)
    q_start = np.asarray(q_start, dtype=float)
    goals = np.atleast_2d(np.asarray(goals, dtype=float))
    for i, q_goal in enumerate(goals):
        direct = np.vstack([q_start, q_goal])
        if certifier.probably_clear(direct) and certifier.path(direct).ok:
            ms = (time.perf_counter() - started) * 1e3
            report = PlannerReport("direct", seed, 1, 2, ms, 0.0, 0.0)
            knots = np.vstack([q_start, q_goal])
            return GeometricPath(knots, knots, BlendedPath(knots), i, report)
    deadline.check("collision-free planning")
    end = started + min(time_limit, deadline.remaining())
    iterations = states = 0
    path = None
    for attempt in range(MAX_ATTEMPTS):
        left = end - time.perf_counter()
        if left <= 0:
            break
        lazy = SearchProblem(
            q_start, goals, lower, upper, lambda q: certifier.state_clear(q, SEARCH_MARGIN), None,
            _seed(seed, attempt), left, MAX_STATES, SEARCH_RESOLUTION, SEARCH_EDGE,
        )  # fmt: skip
        found = sampler.search(lazy)
        iterations, states = iterations + found.iterations, states + found.states
        if found.path is not None:
            search = Repair(certifier, lower, upper, sampler, end)
            path = reduced(search, found.path, _seed(seed, attempt))
            if path is not None:
                break
    search_ms = (time.perf_counter() - started) * 1e3
    if path is None:
        raise NoPathFound(
            f"no collision-free path found within {time_limit:g} s ({iterations} checks, "
            f"{states} states)",
            field=("max_planning_time",),
            extra={"planner": {"name": sampler.name, "seed": seed, "iterations": iterations,
                               "states": states, "plan_time_ms": search_ms}},
        )  # fmt: skip
    goal = int(np.argmin(np.linalg.norm(goals - path[-1], axis=1)))
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    short = shorten(certifier, path, rng, deadline)
    t1 = time.perf_counter()
    smoothed = smooth(certifier, short.knots, lower, upper, deadline)
    t2 = time.perf_counter()
    report = PlannerReport(
        sampler.name, seed, iterations, states, search_ms, (t1 - t0) * 1e3, (t2 - t1) * 1e3
    )
    return GeometricPath(
        smoothed.knots, short.knots, blend(certifier, smoothed.knots), goal, report
    )


def _seed(seed: int, attempt: int) -> int:
    """The seed of a request's ``attempt``-th search (the first: the request's own)."""
    return int(seed) + attempt * 1_000_003


def blend(certifier: Certifier, knots: np.ndarray) -> BlendedPath:
    """``knots`` with a circular blend at every corner, certified by the corner's own margins:
    the arc lies in the triangle of the corner and its two tangent points, so every joint stays
    within ``l max(|y_a,j|, |y_b,j|)`` of the corner, and a pair whose margin there exceeds its
    motion bound over that box stays clear. The blend's reach ``l`` is the largest that every pair
    allows (and within ``BLEND_DEVIATION`` of the corner); under ``MIN_REACH`` the corner stays
    sharp (the motion stops there)."""
    knots = np.asarray(knots, dtype=float)
    W = np.asarray(certifier.clearance.motion_weights, dtype=float)
    deviation = np.zeros(len(knots))
    for k in range(1, len(knots) - 1):
        y_a, y_b = knots[k] - knots[k - 1], knots[k + 1] - knots[k]
        n_a, n_b = float(np.linalg.norm(y_a)), float(np.linalg.norm(y_b))
        if n_a <= 0 or n_b <= 0:
            continue
        y_a, y_b = y_a / n_a, y_b / n_b
        turn = float(np.arccos(np.clip(y_a @ y_b, -1.0, 1.0)))
        rate = W @ np.maximum(np.abs(y_a), np.abs(y_b))
        m = certifier.state_margins(knots[k])
        reach = float(np.min(np.where(rate > 0, m / np.where(rate > 0, rate, 1.0), np.inf)))
        if reach >= MIN_REACH and turn > 0:
            deviation[k] = min(BLEND_DEVIATION, reach * np.tan(turn / 4))
    return BlendedPath(knots, deviation)


@dataclass(frozen=True)
class MotionTask:
    """A collision-free motion request in core terms.

    Attributes:
        q_start: ``(dof,)`` [rad or m].
        goals: The goal (given joints: one candidate) or the IK solutions of a goal pose.
        limits: Joint limits (position, velocity and acceleration needed; jerk for
            ``jerk_limited``).
        timing: One of ``TIMINGS``.
        seed: Integer >= 0.
        max_planning_time: [s] bound of the search.
        sample_period, samples: Sampling of the answer (``core.trajectory.sample_times``).
        max_points: Most returned points.
        joint_names: One per joint.
        deadline: The request's wall-time budget.
        path_limits: What ``time_optimal`` keeps along the path (``core.timing.path_constraints``:
            joint velocity and acceleration, effort), built by the route; default: the velocity
            and acceleration of ``limits``.
        effort: Effort limits with the robot's dynamics, or None: a row of ``path_limits`` for
            ``time_optimal``; a ``jerk_limited`` motion is slowed until its torque keeps them
            (``core.joint.effort.held_motion``).
        dynamics: The robot's dynamics, for ``peak_effort`` (None: none known).
        gravity: Gravity ``(3,)`` [m/s^2] in the base frame for ``peak_effort`` (None: default).
    """

    q_start: np.ndarray
    goals: Goals
    limits: JointLimits
    timing: str = "time_optimal"
    seed: int = 0
    max_planning_time: float = 5.0
    sample_period: float | None = None
    samples: int | None = None
    max_points: int = MAX_POINTS
    joint_names: tuple[str, ...] = ()
    deadline: Deadline = NO_DEADLINE
    path_limits: PathLimits | None = None
    effort: Effort | None = None
    dynamics: Dynamics | None = None
    gravity: np.ndarray | None = None


@dataclass(frozen=True)
class MotionResult:
    """A timed collision-free motion.

    Attributes:
        trajectory: The sampled motion.
        waypoints: ``(K, dof)``: the knots of the geometric path that was timed.
        path_length: [rad] joint-space length of that path (blends included).
        path_length_ratio: ``path_length`` over the straight distance start -> goal (1 when they
            coincide).
        planner: How the path was found.
        goal: ``(dof,)`` the goal reached; ``configuration``: its label (pose goals).
        timing: The timing used (one of ``TIMINGS``).
        clearance: The usual continuous check of the returned motion (``core.collisions``), None
            when no pair is checked.
        peak_effort: |tau| [N m or N] per joint over the motion (None without dynamics).
    """

    trajectory: Trajectory
    waypoints: np.ndarray
    path_length: float
    path_length_ratio: float
    planner: PlannerReport
    goal: np.ndarray
    configuration: str | None
    timing: str
    clearance: ClearanceReport | None = None
    peak_effort: np.ndarray | None = None


def clear_ends(
    task: MotionTask, clearance: GroupClearance, certifier: Certifier, check: Clearance | None
) -> Goals:
    """The start and a goal given as joints through the pipeline's check (``check``:
    ``core.collisions.check_ends``, ``Collision`` with ``at``, the pair and the allowed-collisions
    hint); one within ``CERTIFY_MARGIN`` of a threshold, which no certified motion can leave or
    reach, is answered the same way. A goal pose: its clear IK solutions (``clear_goals``:
    ``Unreachable`` listing each label and its pair when none is)."""
    ends = [End("start", task.q_start, 0.0)]
    if not task.goals.from_pose:
        ends += [End("goal", q) for q in task.goals.positions]
    check_ends(check, tuple(ends))
    for end in ends:
        if check is not None and not certifier.state_ok(np.asarray(end.q)):
            margin = check.distances(np.asarray(end.q)[None])[0] - check.threshold
            pair = int(np.argmin(margin))
            raise end_collision(check, end, pair, float(margin[pair]))
    if not task.goals.from_pose:
        return task.goals
    clear = np.array([certifier.state_ok(q) for q in task.goals.positions])
    return clear_goals(clearance, task.goals, clear)


def plan_motion(
    task: MotionTask,
    clearance: GroupClearance,
    sampler: Sampler = DEFAULT_SAMPLER,
    check: Clearance | None = None,
) -> MotionResult:
    """The timed collision-free motion of ``task`` (module docstring). ``clearance`` is what the
    planner asks, and the usual continuous check of the returned motion runs on it
    (``core.collisions.checked``: its ``check_path`` is the request's own check); ``check`` is the
    request's collision object, which answers for the ends with its real pair names
    (``core.collisions.check_ends``; default: ``clearance`` itself, when it has pairs)."""
    lim = task.limits
    if task.timing not in TIMINGS:
        raise InputError(f"timing must be one of {', '.join(TIMINGS)}", field=("timing",))
    if lim.velocity is None or lim.acceleration is None or lim.position is None:
        raise InputError("velocity and acceleration limits are needed", field=("limits",))
    if task.timing == "jerk_limited" and lim.jerk is None:
        raise InputError(
            "jerk_limited needs jerk limits (the robot has none)", field=("limits", "jerk")
        )
    if check is None and len(clearance.pair_names):
        check = clearance
    certifier = Certifier(clearance)
    goals = clear_ends(task, clearance, certifier, check)
    found = find_path(
        clearance, task.q_start, goals.positions, lim.position[:, 0], lim.position[:, 1],
        seed=task.seed, time_limit=task.max_planning_time, sampler=sampler, deadline=task.deadline,
    )  # fmt: skip
    task.deadline.check("collision-free planning")
    q_goal = goals.positions[found.goal]
    sampling = (task.joint_names, task.sample_period, task.samples, task.max_points)
    if found.path.length <= 0:  # the goal is the start: stand still
        waypoints, length = found.knots[:1], 0.0
        trajectory = stop_and_go_samples(waypoints, lim, *sampling)
    elif task.timing == "jerk_limited":
        waypoints = found.shortened
        trajectory = stop_and_go_samples(waypoints, lim, *sampling)
        length = path_length(waypoints)
    else:
        limits = task.path_limits or PathLimits(lim.velocity, lim.acceleration)
        trajectory, path = certified_samples(
            certifier, found.path, limits, *sampling, deadline=task.deadline
        )
        waypoints, length = found.knots, path.length
    straight = float(np.linalg.norm(q_goal - task.q_start))
    trajectory, peak = held_motion(
        trajectory, task.effort, task.dynamics, task.gravity, task.joint_names, task.deadline
    )
    report = checked(trajectory, clearance if len(clearance.pair_names) else None)
    return MotionResult(
        trajectory, waypoints, float(length), float(length / straight) if straight > 0 else 1.0,
        found.planner, q_goal, goals.labels[found.goal], task.timing, report, peak,
    )  # fmt: skip
