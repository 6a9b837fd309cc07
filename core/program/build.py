"""The walk across segments: every segment's joint samples and every blend's, on one branch.

Segments are planned in order, each from where the last ended:

- PTP: a joint straight line, to goal joints, or to a goal pose: among every IK solution
  (``robot.ik_all``) the one with the requested configuration label nearest the current joints,
  else the nearest of all.
- LIN/CIRC: a Cartesian task on the segment's path (``core.path.PATHS``: ``line``, ``circ``)
  planned by the segment's method from ``core.cartesian.methods.METHODS`` (any method registered
  there plans a program segment), finished and held to the Cartesian 200 rule
  (``core.cartesian.plan.planned``: joint limits, dense deviation, the start's configuration
  label). Its returned points, equally spaced along the path (``samples``), are the segment's
  joint path; their path parameter comes from the path's own closest point.
- Blends: Cartesian-Cartesian in Cartesian space (``BlendPath``, walked by the one IK walk of the
  Cartesian planners, ``core.cartesian.walk``), anything with a PTP in joint space
  (``joint_blend``).

A failure is raised with ``extra["segment"]`` and ``s`` within that segment (a request field
named by a segment's Cartesian task is prefixed with ``segments.<i>``); with ``allow_partial``,
``build`` returns what was planned before it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from core.cartesian.ik_on_path import IK_SOLVE_TOLERANCE, IK_TOLERANCE, residual, solve_ik
from core.cartesian.plan import planned as cartesian_planned
from core.cartesian.plan import planner_of
from core.cartesian.task import CartesianTask, PathSpec
from core.cartesian.walk import walk_line
from core.cartesian.walk_batch import batch_walk
from core.errors import BranchFlip, InputError, JointLimit, PlanningError, Unreachable
from core.kinematics import Kinematics
from core.limits import outside, worst_joint
from core.program.geometry.blend import BlendPath, joint_blend, pose_blend, sphere_crossing
from core.program.geometry.paths import (
    PATH_KINDS,
    SegmentPath,
    cartesian_path,
    intervals,
    sample_grid,
)
from core.program.ptp_planned import planned_ptp, planned_segment
from core.program.segments import ProgramTask, Segment
from core.program.validate import Layout

BLEND_INTERVALS = 40
"""Sample intervals of a blend: as dense as the segments near it, so the path spline through the
samples stays on the line or arc across the junction."""
BLEND_JOIN = 1e-4
"""Largest joint gap [rad] between a Cartesian blend's IK end and the next segment's samples."""


@dataclass(frozen=True)
class Blend:
    """The transition out of segment ``after`` (the index in the request).

    Attributes:
        after: Index of the incoming segment.
        cartesian: Mixed in Cartesian space (else joint space).
        q: Joint samples (K, dof), from the incoming segment's exit to the outgoing one's entry.
        T: Tool poses at them (K, 4, 4).
    """

    after: int
    cartesian: bool
    q: np.ndarray
    T: np.ndarray


@dataclass(frozen=True)
class Geometry:
    """The program's joint path: planned segments in order and the blends between them."""

    segments: tuple[SegmentPath, ...]
    blends: dict[int, Blend]
    failure: PlanningError | None
    failed_segment: int | None
    failed_s: float


def _tag(err: PlanningError, index: int, s: float | None = None) -> PlanningError:
    err.extra["segment"] = index
    if s is not None:
        err.s = s
    return err


def _ptp_goal(task: ProgramTask, i: int, seg: Segment, q: np.ndarray) -> np.ndarray:
    robot = task.robot
    if seg.goal_positions is not None:
        goal = np.asarray(seg.goal_positions, dtype=float)
        if outside(goal, robot.position_limits).any():
            raise InputError(
                "goal.positions outside the joint limits",
                field=("segments", i, "goal", "positions"),
            )
        return goal
    labels = tuple(robot.configuration_labels)
    field = ("segments", i, "goal", "configuration")
    if seg.configuration is not None and not labels:
        raise InputError("this robot has no configuration labels", field=field)
    if seg.configuration is not None and seg.configuration not in labels:
        raise InputError(
            f"unknown configuration label; this robot's labels are {', '.join(labels)}",
            field=field,
            extra={"configurations": list(labels)},
        )
    sols = robot.ik_all(seg.goal_pose, q)  # type: ignore[arg-type]
    if len(sols.positions) == 0:
        raise _tag(Unreachable(f"no IK solution for segment {i}'s goal pose within limits"), i, 1.0)
    Q = np.asarray(sols.positions, dtype=float)
    if seg.configuration is None:
        pick = np.arange(len(Q))
    else:
        pick = np.flatnonzero([c == seg.configuration for c in sols.configurations])
        if not pick.size:
            found = sorted({c for c in sols.configurations if c is not None})
            raise _tag(
                Unreachable(
                    f"segment {i}'s goal pose has no IK solution with configuration "
                    f"{seg.configuration!r} within the limits; it has {', '.join(found)}",
                    extra={"configurations": found},
                ),
                i,
                1.0,
            )
    # Nearest the current joints (ik_all sorts by distance already; made explicit here).
    return Q[pick[int(np.argmin(np.linalg.norm(Q[pick] - q, axis=1)))]]


def segment_task(task: ProgramTask, seg: Segment, q: np.ndarray, goal: np.ndarray, n: int):
    """The Cartesian task of a LIN/CIRC segment from ``q`` to the pose ``goal``, asking its method
    for ``n + 1`` returned points equally spaced along the path."""
    return CartesianTask(
        robot=task.robot,
        q_start=q,
        T_goal=goal,
        q_goal=seg.goal_positions,
        position_tolerance=seg.position_tolerance,
        orientation_tolerance=seg.orientation_tolerance,
        max_linear_speed=seg.tool_speeds()[0] if np.isfinite(seg.tool_speeds()[0]) else None,
        max_angular_speed=seg.tool_speeds()[1] if np.isfinite(seg.tool_speeds()[1]) else None,
        samples=n + 1,
        allow_partial=task.allow_partial,
        deadline=task.deadline,
        path=PathSpec(PATH_KINDS[seg.type], interim=seg.interim, center=seg.center),
        speed_profile=seg.speed_profile,
        max_linear_jerk=seg.max_linear_jerk,
        max_angular_jerk=seg.max_angular_jerk,
        max_linear_acceleration=seg.tool_accelerations()[0],
        max_angular_acceleration=seg.tool_accelerations()[1],
    )


def _cartesian(
    task: ProgramTask, lay: Layout, i: int, q: np.ndarray, r_in: float, r_out: float
) -> tuple[SegmentPath, PlanningError | None]:
    """A LIN/CIRC segment planned by its method (see the module docstring): its samples on the
    program's grid (cuts included), and the failure that ended a partial plan."""
    robot, seg = task.robot, task.segments[i]
    path = cartesian_path(seg, robot.fk(q), lay.goals[i], robot.task_space, i)

    def positions(s: np.ndarray) -> np.ndarray:
        return path.poses(s)[:, :3, 3]

    s_in, s_out = _cuts(positions, r_in, r_out, i)
    n = intervals(seg, path, np.zeros(0))
    try:
        result = cartesian_planned(
            segment_task(task, seg, q, lay.goals[i], n), planner_of(seg.method)
        )
    except PlanningError as err:
        if err.field is not None:
            err.field = ("segments", i, *err.field)
        raise
    qs = result.trajectory.positions
    s = path.deviation(robot.fk_many(qs), seg.position_tolerance, seg.orientation_tolerance).s
    s[0], end = 0.0, float(result.fraction)
    s[-1] = end
    keep = np.concatenate([[True], np.diff(np.maximum.accumulate(s)) > 1e-12])
    keep[-1] = True
    s_k, q_k = np.maximum.accumulate(s)[keep], qs[keep]
    grid = sample_grid(n, s_in, s_out, BLEND_INTERVALS)
    grid = np.union1d(grid[grid < end], [end]) if end < 1.0 else grid
    sp = SegmentPath(i, seg, path, q, grid, q_k[:1], s_in, s_out, planned=(s_k, q_k))
    sp.q = sp.joints(grid)
    sp.q[0], sp.q[-1] = q_k[0], q_k[-1]
    for cut in {s_in, s_out} - {0.0, 1.0}:  # blend boundaries on the path, to IK's precision
        k = int(np.argmin(np.abs(grid - cut)))
        sp.q[k] = _on_path(robot, path.pose(cut), sp.q[k])
    sp.min_singular_value = float(result.min_singular_value)
    if result.knots is not None:
        sp.knot_count = len(result.knots["s"])
    failure = result.failure if isinstance(result.failure, PlanningError) else None
    return sp, failure


def _on_path(robot: Kinematics, T: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``q`` (dof,), a point of a segment's joint spline, moved onto the pose ``T`` by IK from it
    (kept as it is when IK does not land within ``IK_TOLERANCE`` of it)."""
    r = solve_ik(robot, T, q)
    q_ik = np.asarray(r.positions, dtype=float)
    close = residual(r) <= IK_SOLVE_TOLERANCE and np.abs(q_ik - q).max() <= IK_TOLERANCE
    return q_ik if close else q


def _cuts(positions, r_in: float, r_out: float, i: int) -> tuple[float, float]:
    """Where the tool leaves the incoming blend sphere and enters the outgoing one."""
    p = positions(np.array([0.0, 1.0]))
    s_in = sphere_crossing(positions, p[0], r_in, last=False) if r_in > 0 else 0.0
    s_out = sphere_crossing(positions, p[1], r_out, last=True) if r_out > 0 else 1.0
    if s_out <= s_in:
        raise InputError(
            f"the blend spheres at both ends of segment {i} overlap along its path",
            field=("segments", i, "blend_radius"),
        )
    return s_in, s_out


def _ptp(task: ProgramTask, i: int, q: np.ndarray, r_in: float, r_out: float) -> SegmentPath:
    robot, seg = task.robot, task.segments[i]
    goal = _ptp_goal(task, i, seg, q)
    planned = planned_ptp(task, i, q, goal) if np.abs(goal - q).max() > 0.0 else None
    if planned is not None:  # the collision-free planner's joint path
        goal, found = planned
        length = float(found.path.length)

        def along(s: np.ndarray) -> np.ndarray:
            return robot.fk_many(found.path(s * length))[:, :3, 3]

        sp = planned_segment(i, task, q, found, _cuts(along, r_in, r_out, i))
        sp.q[-1] = goal
        return sp
    dq = goal - q

    def positions(s: np.ndarray) -> np.ndarray:
        return robot.fk_many(q + s[:, None] * dq)[:, :3, 3]

    s_in, s_out = _cuts(positions, r_in, r_out, i)
    grid = sample_grid(intervals(seg, None, dq), s_in, s_out, BLEND_INTERVALS)
    return SegmentPath(i, seg, None, q, grid, q + grid[:, None] * dq, s_in, s_out)


def build(task: ProgramTask, lay: Layout) -> Geometry:
    """Plan every segment's and blend's joint samples (see the module docstring)."""
    q = np.asarray(task.q_start, dtype=float)
    planned: list[SegmentPath] = []
    r_in = 0.0
    for i in lay.active:
        seg, r_out = task.segments[i], lay.blends[i]
        try:
            if seg.type == "ptp":
                sp, failure = _ptp(task, i, q, r_in, r_out), None
            else:
                sp, failure = _cartesian(task, lay, i, q, r_in, r_out)
        except PlanningError as err:
            if "segment" not in err.extra and not isinstance(err, InputError):
                _tag(err, i)
            if isinstance(err, InputError) or not task.allow_partial or not planned:
                raise
            return _partial(task, planned, err, i)
        if failure is not None:  # a partial plan of this segment: the program ends in it
            _tag(failure, i)
            if sp.s[-1] <= sp.s_in + 1e-9:
                if not planned:
                    raise failure
                return _partial(task, planned, failure, i)
            sp.s_out = float(sp.s[-1])
            planned.append(sp)
            return Geometry(tuple(planned), _blends(task, planned), failure, i, float(sp.s[-1]))
        sp.blend_out = r_out > 0.0
        planned.append(sp)
        q, r_in = sp.q_goal, r_out
    try:
        return Geometry(tuple(planned), _blends(task, planned), None, None, 1.0)
    except PlanningError as err:
        failed = int(err.extra.get("segment", 0))
        keep = [p for p in planned if p.index <= failed]
        if not task.allow_partial:
            raise
        return _partial(task, keep, err, failed)


def _partial(task: ProgramTask, planned: list[SegmentPath], err: PlanningError, i: int) -> Geometry:
    """What was planned before failure ``err`` at segment ``i``: the last planned segment stops at
    its goal (its blend dropped; its samples beyond the exit are used again)."""
    last = planned[-1]
    last.blend_out, last.s_out = False, 1.0
    s = 1.0 if last.index == i else (float(err.s) if err.s is not None else 0.0)
    return Geometry(tuple(planned), _blends(task, planned), err, i, s)


def _blends(task: ProgramTask, planned: list[SegmentPath]) -> dict[int, Blend]:
    out: dict[int, Blend] = {}
    for a, b in itertools.pairwise(planned):
        if not a.blend_out:
            continue
        task.deadline.check("blends")
        u = np.linspace(0.0, 1.0, BLEND_INTERVALS + 1)
        if a.path is not None and b.path is not None:
            out[a.index] = _cartesian_blend(task, a, b, u)
        else:
            out[a.index] = _joint_blend(task, a, b, u)
    return out


def _cartesian_blend(task: ProgramTask, a: SegmentPath, b: SegmentPath, u: np.ndarray) -> Blend:
    """The pose blend between LIN/CIRC ``a`` and ``b``, walked by ``core.cartesian.walk``."""
    robot = task.robot
    span_a, span_b = 1.0 - a.s_out, b.s_in
    path_a, path_b = a.path, b.path
    assert path_a is not None and path_b is not None

    def poses_a(x: np.ndarray) -> np.ndarray:
        return path_a.poses(a.s_out + x * span_a)

    def poses_b(x: np.ndarray) -> np.ndarray:
        return path_b.poses(x * span_b)

    blend = BlendPath(pose_blend(poses_a, poses_b), robot.task_space)
    q0 = a.joints(np.array([a.s_out]))[0]
    sa, sb = a.seg, b.seg
    walk_task = CartesianTask(
        robot=robot,
        q_start=q0,
        T_goal=blend.T_goal,
        position_tolerance=min(sa.position_tolerance, sb.position_tolerance),
        orientation_tolerance=min(sa.orientation_tolerance, sb.orientation_tolerance),
        max_linear_speed=float(min(sa.tool_speeds()[0], sb.tool_speeds()[0])),
        max_angular_speed=float(min(sa.tool_speeds()[1], sb.tool_speeds()[1])),
        deadline=task.deadline,
    )
    try:
        w = batch_walk(walk_task, blend, u) or walk_line(walk_task, blend, u)  # type: ignore[arg-type]
    except PlanningError as err:
        raise _tag(err, a.index, a.s_out + float(err.s or 0.0) * span_a) from None
    if w.failure is not None:
        raise _tag(w.failure, a.index, a.s_out + float(w.failure.s or 0.0) * span_a)
    q_end = b.joints(np.array([b.s_in]))[0]
    gap = float(np.abs(w.positions[-1] - q_end).max())
    if gap > BLEND_JOIN:
        raise _tag(
            BranchFlip(
                f"the blend after segment {a.index} arrives on another branch than segment "
                f"{b.index} ({gap:.3g} rad apart)"
            ),
            a.index,
            1.0,
        )
    qs = w.positions.copy()
    qs[-1] = q_end
    return Blend(a.index, True, qs, blend.poses(w.s))


def _joint_blend(task: ProgramTask, a: SegmentPath, b: SegmentPath, u: np.ndarray) -> Blend:
    """The joint-space blend between ``a`` and ``b`` (one of them a PTP)."""
    robot = task.robot
    span_a, span_b = 1.0 - a.s_out, b.s_in

    def joints_a(x: np.ndarray) -> np.ndarray:
        return a.joints(a.s_out + x * span_a)

    def joints_b(x: np.ndarray) -> np.ndarray:
        return b.joints(x * span_b)

    qs = joint_blend(joints_a, joints_b, u)
    over = outside(qs, robot.position_limits)
    if over.any():
        j = worst_joint(qs[over.any(axis=1)][0], robot.position_limits)
        raise _tag(
            JointLimit(f"the blend after segment {a.index} leaves joint {j}'s limits", joint=j),
            a.index,
            1.0,
        )
    return Blend(a.index, False, qs, robot.fk_many(qs))
