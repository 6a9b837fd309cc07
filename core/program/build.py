"""Geometry first: every segment's joint samples and every blend's, on one branch.

Segments are planned in order, each from where the last ended: PTP as a joint straight line (to
goal joints, or to a goal pose: among every IK solution (``robot.ik_all``) the one with the
requested configuration label nearest the current joints, else the nearest of all), LIN and CIRC
by IK along the line or arc (``core.program.walk``), keeping the configuration label of their
start (``robot.configurations``; a change is ``BranchFlip`` where it happens). Then each
blend: Cartesian-Cartesian in Cartesian space (``pose_blend``, then IK seeded from the incoming
segment), anything with a PTP in joint space (``joint_blend``). A failure is raised with
``extra["segment"]`` and ``s`` within that segment; ``build`` returns what was planned before it
when the caller asks for a partial plan.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from core.errors import BranchFlip, InputError, JointLimit, PlanningError, Unreachable
from core.program.geometry.blend import joint_blend, pose_blend, sphere_crossing
from core.program.geometry.knots import knot_spline
from core.program.geometry.paths import SegmentPath, cartesian_path, sample_grid
from core.program.segments import ProgramTask, Segment
from core.program.validate import Layout
from core.program.walk import Walk, walk

BLEND_INTERVALS = 40
"""Sample intervals of a blend: as dense as the segments near it, so the path spline through the
samples stays on the line or arc across the junction (12 intervals let it stray 1.2e-6 m)."""
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
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    if seg.goal_positions is not None:
        goal = np.asarray(seg.goal_positions, dtype=float)
        if np.any(goal < lo) or np.any(goal > hi):
            raise InputError(
                "goal.positions outside the joint limits",
                field=("segments", i, "goal", "positions"),
            )
        return goal
    labels = tuple(robot.configuration_labels)
    if seg.configuration is not None and not labels:
        raise InputError(
            "this robot has no configuration labels",
            field=("segments", i, "goal", "configuration"),
        )
    if seg.configuration is not None and seg.configuration not in labels:
        raise InputError(
            f"unknown configuration label; this robot's labels are {', '.join(labels)}",
            field=("segments", i, "goal", "configuration"),
            extra={"configurations": list(labels)},
        )
    sols = robot.ik_all(seg.goal_pose, q)
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


def _keep_label(robot, w: Walk) -> Walk:
    """``w`` cut before the first sample whose configuration label differs from its start's: a
    LIN/CIRC (or a Cartesian blend) keeps the label it starts with; a change is ``BranchFlip``."""
    k = _label_change(robot, w.q)
    if k is None:
        return w
    labels = robot.configurations(w.q[[0, k]])
    flip = BranchFlip(
        f"the configuration would change from {labels[0]!r} to {labels[1]!r} at s={w.s[k]:.4f}: "
        "LIN and CIRC keep the configuration of their start",
        s=float(w.s[k]),
        extra={"configurations": list(labels)},
    )
    return replace(w, s=w.s[:k], q=w.q[:k], failure=flip)


def _label_change(robot, q: np.ndarray) -> int | None:
    """Index of the first row of ``q`` (K, dof) whose configuration label differs from row 0's,
    or None (also for robots without labels)."""
    if len(q) < 2:
        return None
    labels = robot.configurations(q)
    if labels[0] is None:
        return None
    bad = [k for k, c in enumerate(labels) if c != labels[0]]
    return bad[0] if bad else None


def build(task: ProgramTask, lay: Layout) -> Geometry:
    """Plan every segment's and blend's joint samples (see the module docstring)."""
    robot = task.robot
    q = np.asarray(task.q_start, dtype=float)
    planned: list[SegmentPath] = []
    r_in = 0.0
    for i in lay.active:
        seg = task.segments[i]
        try:
            T_start = robot.fk(q)
            p_start = T_start[:3, 3]
            r_out = lay.blends[i]
            if seg.type == "ptp":
                q_goal = _ptp_goal(task, i, seg, q)
                dq = q_goal - q

                def positions(s: np.ndarray, q0=q, dq=dq) -> np.ndarray:
                    return robot.fk_many(q0 + s[:, None] * dq)[:, :3, 3]

                path = None
            else:
                dq = np.zeros_like(q)
                path = cartesian_path(seg, T_start, lay.goals[i], robot.task_space, i)
                positions = path.positions
            s_in = sphere_crossing(positions, p_start, r_in, last=False) if r_in > 0 else 0.0
            p_goal = positions(np.array([1.0]))[0]
            s_out = sphere_crossing(positions, p_goal, r_out, last=True) if r_out > 0 else 1.0
            if s_out <= s_in:
                raise InputError(
                    f"the blend spheres at both ends of segment {i} overlap along its path",
                    field=("segments", i, "blend_radius"),
                )
            grid = sample_grid(seg, path, dq, [s_in, s_out])
            if path is None:
                sp = SegmentPath(i, seg, None, q, grid, q + grid[:, None] * dq, s_in, s_out)
            else:
                w = _keep_label(robot, walk(robot, path.poses, q, grid, task.deadline))
                sp = SegmentPath(i, seg, path, q, w.s, w.q, s_in, s_out)
                if seg.method == "bounded_deviation" and w.failure is None:
                    knots, sp.q = knot_spline(
                        robot, path, w.s, w.q, [s_in, s_out],
                        seg.position_tolerance, seg.orientation_tolerance,
                    )  # fmt: skip
                    sp.knot_count = len(knots)
                sp.min_singular_value = w.min_singular_value
                if w.failure is not None:
                    _tag(w.failure, i)
                    if not task.allow_partial or (not planned and len(w.s) < 2):
                        raise w.failure
                    if w.s[-1] <= s_in + 1e-9:
                        return _partial(task, planned, w.failure, i)
                    sp.s_out = float(w.s[-1])
                    planned.append(sp)
                    blends = _blends(task, planned)
                    return Geometry(tuple(planned), blends, w.failure, i, float(w.s[-1]))
        except PlanningError as err:
            if "segment" not in err.extra and not isinstance(err, InputError):
                _tag(err, i)
            if isinstance(err, InputError) or not task.allow_partial or not planned:
                raise
            return _partial(task, planned, err, i)
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
    robot = task.robot
    out: dict[int, Blend] = {}
    for a, b in itertools.pairwise(planned):
        if not a.blend_out:
            continue
        task.deadline.check("blends")
        span_a, span_b = 1.0 - a.s_out, b.s_in

        def sa(u: np.ndarray, a=a, span_a=span_a) -> np.ndarray:
            return a.s_out + u * span_a

        def sb(u: np.ndarray, b=b, span_b=span_b) -> np.ndarray:
            return u * span_b

        u = np.linspace(0.0, 1.0, BLEND_INTERVALS + 1)
        if a.path is not None and b.path is not None:
            poses = pose_blend(
                lambda x, a=a, sa=sa: a.path.poses(sa(x)), lambda x, b=b, sb=sb: b.path.poses(sb(x))
            )
            q0 = a.joints(np.array([a.s_out]))[0]
            w = _keep_label(robot, walk(robot, poses, q0, u, task.deadline))
            if w.failure is not None:
                raise _tag(w.failure, a.index, a.s_out + float(w.failure.s or 0.0) * span_a)
            q_end = b.joints(np.array([b.s_in]))[0]
            gap = float(np.abs(w.q[-1] - q_end).max())
            if gap > BLEND_JOIN:
                raise _tag(
                    BranchFlip(
                        f"the blend after segment {a.index} arrives on another branch than segment "
                        f"{b.index} ({gap:.3g} rad apart)"
                    ),
                    a.index,
                    1.0,
                )
            qs = w.q.copy()
            qs[-1] = q_end
            Ts = poses(w.s)
            out[a.index] = Blend(a.index, True, qs, Ts)
        else:
            qs = joint_blend(
                lambda x, a=a, sa=sa: a.joints(sa(x)), lambda x, b=b, sb=sb: b.joints(sb(x)), u
            )
            lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
            if np.any(qs < lo - 1e-9) or np.any(qs > hi + 1e-9):
                j = int(np.argmax(np.maximum(lo - qs, qs - hi).max(axis=0)))
                raise _tag(
                    JointLimit(
                        f"the blend after segment {a.index} leaves joint {j}'s limits", joint=j
                    ),
                    a.index,
                    1.0,
                )
            out[a.index] = Blend(a.index, False, qs, robot.fk_many(qs))
    return out
