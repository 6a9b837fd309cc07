"""A PTP segment whose joint motion the collision-free planner finds (``planner: collision_free``).

With an environment (``ProgramTask.planner_clearance``), a PTP segment that asks for it is not the
straight joint segment but the path of ``core.motion.plan.find_path`` from where the program is to
the segment's goal: the direct segment when it is clear, else RRT-Connect, shortened, smoothed and
blended at its corners, every part certified. A goal given as joints is that goal (the program
checked it before planning); a goal pose tries its IK solutions with the asked configuration label,
clear ones only, nearest the current joints first (``core.motion.goals``). The search is
deterministic per program ``seed`` and bounded by the request's time budget (less
``PLANNER_RESERVE`` for what follows it). Without an environment the PTP stays the straight
segment.

The segment then is an ordinary PTP whose joint path is the planner's (``SegmentPath.joint_path``,
s in [0, 1] its share of the path's length): its samples (every ``PTP_STEP`` and ``ARC_SAMPLES``
more within every piece of the path, so the program's spline through them follows the blends'
arcs) place the blend spheres of its neighbours like any PTP's, and the program's own continuous
check covers the whole timed motion.
"""

from __future__ import annotations

import numpy as np

from core.errors import InputError, PlanningError
from core.motion.certify import Certifier
from core.motion.goals import clear_goals, pose_goals
from core.motion.plan import GeometricPath, find_path
from core.program.geometry.paths import MIN_INTERVALS, PTP_STEP, SegmentPath, sample_grid
from core.program.segments import ProgramTask

PLANNERS = ("collision_free",)
"""The planners a PTP segment may ask for."""
PLANNER_RESERVE = 1.0
"""[s] Of the request's remaining time budget, kept for what follows a search (timing, the
continuous check, encoding)."""
ARC_SAMPLES = 8
"""Extra samples inside every piece (line or arc) of a planned path."""
BLEND_INTERVALS = 40


def planned_goals(task: ProgramTask, i: int, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The candidate goals ``(k, dof)`` of PTP segment ``i`` from ``q``: its goal joints, or the
    clear IK solutions of its goal pose (``goal``: the one the straight PTP would take, first)."""
    seg, clearance = task.segments[i], task.planner_clearance
    if seg.goal_positions is not None or seg.goal_pose is None or clearance is None:
        return goal[None]
    try:
        goals = pose_goals(
            task.robot, np.asarray(seg.goal_pose), q, seg.configuration, task.deadline
        )
        certifier = Certifier(clearance)
        clear = np.array([certifier.state_ok(g) for g in goals.positions])
        return clear_goals(clearance, goals, clear).positions
    except PlanningError as err:
        if err.field is not None:
            err.field = ("segments", i, *err.field)
        err.extra["segment"] = i
        raise


def planned_ptp(
    task: ProgramTask, i: int, q: np.ndarray, goal: np.ndarray
) -> tuple[np.ndarray, GeometricPath] | None:
    """``(goal reached, the planner's path)`` of PTP segment ``i`` from ``q``; None when it asks
    for no planner or the program has no environment."""
    seg, clearance = task.segments[i], task.planner_clearance
    if seg.planner is None or clearance is None:
        return None
    goals = planned_goals(task, i, q, goal)
    lower, upper = np.asarray(task.robot.position_limits, dtype=float).T
    budget = max(task.deadline.remaining() - PLANNER_RESERVE, 0.0)
    try:
        found = find_path(
            clearance, q, goals, lower, upper, seed=task.seed, time_limit=budget,
            deadline=task.deadline,
        )  # fmt: skip
    except PlanningError as err:
        err.extra["segment"] = i
        if not isinstance(err, InputError):
            err.field = ("segments", i, "planner")
        raise
    return goals[found.goal], found


def planned_segment(
    i: int, task: ProgramTask, q: np.ndarray, found: GeometricPath, s_cuts: tuple[float, float]
) -> SegmentPath:
    """The ``SegmentPath`` of a planned PTP: samples along the planner's path (module
    docstring) with the blend cuts ``s_cuts``; ``planner``: how it was found."""
    path = found.path
    length = float(path.length)
    s_in, s_out = s_cuts
    n = max(MIN_INTERVALS, int(np.ceil(length / PTP_STEP)))
    grid = sample_grid(n, s_in, s_out, BLEND_INTERVALS)
    b = np.asarray(path.breakpoints(), dtype=float) / length
    inner = b[:-1, None] + np.diff(b)[:, None] * np.arange(1, ARC_SAMPLES + 1) / (ARC_SAMPLES + 1)
    extra = np.concatenate([b, inner.ravel()])
    extra = extra[(extra > s_in) & (extra < s_out)]
    grid = np.unique(np.concatenate([grid, extra]))
    grid = grid[np.concatenate([[True], np.diff(grid) > 1e-9])]
    sp = SegmentPath(i, task.segments[i], None, q, grid, np.zeros((0, len(q))), s_in, s_out)
    sp.joint_path = path
    sp.planner = {**found.planner.as_dict(), "path_length": length}
    sp.q = sp.joints(grid)
    sp.q[0] = q
    return sp
