"""A motion program as one trajectory: validate -> geometry (``build``) -> timing -> samples.

The joint path is cut into chunks at every stop (an unblended segment goal); blended corners stay
inside a chunk. Each chunk is timed as one rest-to-rest motion (``core.program.timing``; an
S-curve when one of its LIN/CIRC segments asks for ``speed_profile="s_curve"``), so the program
stops exactly at unblended goals and nowhere else. A chunk that is a lone PTP with a ``profile``
is timed by that joint profile instead (``core.joint.point_to_point.plan_joint``: trapezoidal,
quintic, or jerk_limited on Ruckig), under the joint limits times the segment's scales. The returned points are a regular grid
(``sample_period`` or ``samples``) plus every segment boundary and blend window boundary, so a
controller reaches each goal exactly. LIN/CIRC deviation from their line/arc is measured outside
the blend windows along the returned trajectory (``core.program.report``). The trajectory's
peaks (``peak_jerk`` included) are those of the analytic q(t) of every chunk.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core.errors import InputError, PlanningError, TooLarge
from core.joint.motion import PointToPoint
from core.joint.point_to_point import plan_joint
from core.limits import JointLimits
from core.program.build import Geometry, build
from core.program.chunk import ChunkInput, ChunkTiming
from core.program.report import ProgramResult, SegmentResult, report
from core.program.s_curve import ShapedSCurve
from core.program.segments import ANGULAR_ACCELERATION, LINEAR_ACCELERATION, ProgramTask
from core.program.timing import time_chunk
from core.program.validate import layout
from core.timing.s_curve import SCurveTiming
from core.trajectory import MAX_POINTS, Peaks, Profile, Trajectory, sample_times

_MIN_GAP = 1e-6
"""Regular sample times closer than this [s] to a boundary time are dropped (the boundary stays)."""


@dataclass
class _Piece:
    owner: int
    blend: bool
    q: np.ndarray
    T: np.ndarray
    scales: tuple[float, float]
    tool_speed: tuple[float, float]
    tool_acc: tuple[float, float]
    times: tuple[float, float] = (0.0, 0.0)


def _pieces(task: ProgramTask, geo: Geometry) -> list[list[_Piece]]:
    """The geometry as chunks (lists of pieces between stops)."""
    robot = task.robot
    chunks: list[list[_Piece]] = [[]]
    for sp in geo.segments:
        seg = sp.seg
        s, q = sp.piece()
        # a knot spline (bounded_deviation) leaves the path within its tolerance: the tool's own
        # poses, so its speed limits hold for the tool itself
        T = sp.poses(robot, s) if sp.knot_count is None else robot.fk_many(q)
        cart = seg.cartesian
        acc = (LINEAR_ACCELERATION, ANGULAR_ACCELERATION) if cart else (np.inf, np.inf)
        piece = _Piece(
            sp.index,
            False,
            q,
            T,
            (seg.velocity_scale, seg.acceleration_scale),
            seg.tool_speeds(),
            acc,
        )
        chunks[-1].append(piece)
        blend = geo.blends.get(sp.index)
        if blend is None:
            chunks.append([])
            continue
        nxt = next(p for p in geo.segments if p.index > sp.index).seg
        chunks[-1].append(
            _Piece(
                sp.index,
                True,
                blend.q,
                blend.T,
                (
                    min(seg.velocity_scale, nxt.velocity_scale),
                    min(seg.acceleration_scale, nxt.acceleration_scale),
                ),
                tuple(np.minimum(seg.tool_speeds(), nxt.tool_speeds())),
                (LINEAR_ACCELERATION, ANGULAR_ACCELERATION) if blend.cartesian else acc,
            )
        )
    return [c for c in chunks if c]


def _time(task: ProgramTask, chunk: list[_Piece]) -> ChunkTiming | None:
    """Time one chunk; record each piece's (start, end) time in the chunk. None if it is still."""
    robot = task.robot
    qs, Ts, starts = [], [], []
    rows: dict[str, list[np.ndarray]] = {"v": [], "a": [], "ts": [], "ta": []}
    for k, p in enumerate(chunk):
        first = 0 if k == 0 else 1  # pieces share their junction sample
        starts.append(sum(len(x) for x in qs) - (0 if k == 0 else 1))
        n = len(p.q) - first
        qs.append(p.q[first:])
        Ts.append(p.T[first:])
        rows["v"].append(np.tile(robot.velocity_limits * p.scales[0], (n, 1)))
        rows["a"].append(np.tile(robot.acceleration_limits * p.scales[1], (n, 1)))
        rows["ts"].append(np.tile(p.tool_speed, (n, 1)))
        rows["ta"].append(np.tile(p.tool_acc, (n, 1)))
    q = np.concatenate(qs)
    ends = [*starts[1:], len(q) - 1]
    step = np.linalg.norm(np.diff(q, axis=0), axis=1)
    if step.sum() < 1e-12:
        return None
    keep = np.concatenate([[True], step > 1e-13])
    index = np.cumsum(keep) - 1  # old sample -> kept sample
    asking = [
        task.segments[p.owner]
        for p in chunk
        if not p.blend and task.segments[p.owner].speed_profile == "s_curve"
    ]
    jerk = None
    if asking:  # one S-curve for the stretch, under the tightest jerk limits asked
        jerk = tuple(np.min([seg.tool_jerks() for seg in asking], axis=0).tolist())
    c = ChunkInput(
        q[keep],
        np.concatenate(Ts)[keep],
        np.concatenate(rows["v"])[keep],
        np.concatenate(rows["a"])[keep],
        np.concatenate(rows["ts"])[keep],
        np.concatenate(rows["ta"])[keep],
        jerk,
    )
    timing = time_chunk(c)
    for p, a, b in zip(chunk, starts, ends, strict=True):
        p.times = (float(timing.knot_times[index[a]]), float(timing.knot_times[index[b]]))
    return timing


@dataclass(frozen=True)
class ProfileTiming:
    """A chunk that is one unblended PTP, timed by its joint profile (``plan_joint``): rest to
    rest, sampled exactly (``sample`` as ``ChunkTiming.sample``).

    Attributes:
        profile: The joint profile (``core.joint.profiles``), t in [0, duration] [s].
        duration: Its length [s].
        stretch: 1.0 (the profile is timed within the limits by construction).
    """

    profile: Profile
    duration: float
    stretch: float = 1.0

    def peaks(self) -> Peaks:
        """The profile's exact peaks."""
        return self.profile.peaks()

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations (N, dof) at times ``t`` (N,) [s]."""
        return self.profile.sample(np.clip(np.asarray(t, dtype=float), 0.0, self.duration))


def _profiled(task: ProgramTask, chunk: list[_Piece]) -> str | None:
    """The joint profile a chunk is timed with: a lone PTP piece (rest to rest) that asks for one."""
    if len(chunk) != 1 or chunk[0].blend:
        return None
    seg = task.segments[chunk[0].owner]
    return seg.profile if seg.type == "ptp" else None


def _profile_time(task: ProgramTask, chunk: list[_Piece], kind: str) -> ProfileTiming | None:
    """Time a lone PTP with joint profile ``kind`` under its scaled limits; None if it is still."""
    robot, p = task.robot, chunk[0]
    seg = task.segments[p.owner]
    q0, q1 = p.q[0], p.q[-1]
    if np.abs(q1 - q0).max() < 1e-12:
        return None
    limits = JointLimits(
        velocity=np.asarray(robot.velocity_limits, dtype=float) * seg.velocity_scale,
        acceleration=np.asarray(robot.acceleration_limits, dtype=float) * seg.acceleration_scale,
        position=np.asarray(robot.position_limits, dtype=float),
        jerk=robot.jerk_limits,
    )
    try:
        plan = plan_joint(
            kind,
            PointToPoint.create(q0, q1),
            limits,
            samples=2,
            joint_names=tuple(robot.joint_names),
            deadline=task.deadline,
        )
    except PlanningError as err:
        err.extra["segment"] = p.owner
        if isinstance(err, InputError):
            err.field = ("segments", p.owner, "profile")
        raise
    duration = float(plan.profile.duration)
    p.times = (0.0, duration)
    return ProfileTiming(plan.profile, duration)


def plan_program(task: ProgramTask) -> ProgramResult:
    """Plan ``task`` (see the module docstring)."""
    lay = layout(task)
    geo = build(task, lay)
    robot = task.robot
    chunks = _pieces(task, geo)
    timings: list[tuple[float, ChunkTiming | ProfileTiming, list[_Piece]]] = []
    offset = 0.0
    profiled: set[int] = set()
    timed_by: dict[int, str] = {}
    for chunk in chunks:
        task.deadline.check("timing the program")
        kind = _profiled(task, chunk)
        try:
            timing = _time(task, chunk) if kind is None else _profile_time(task, chunk, kind)
        except PlanningError as err:  # e.g. an S-curve over Ruckig's duration cap
            err.extra.setdefault("segment", chunk[0].owner)
            raise
        if kind is not None:
            profiled.add(chunk[0].owner)
        elif timing is not None:
            kind = (
                "s_curve" if isinstance(timing.law, SCurveTiming | ShapedSCurve) else "time_optimal"
            )
        for p in chunk:
            if not p.blend:
                timed_by[p.owner] = kind or "time_optimal"
        if timing is None:
            continue
        for p in chunk:
            p.times = (p.times[0] + offset, p.times[1] + offset)
        timings.append((offset, timing, chunk))
        offset += timing.duration
    if not timings:
        raise InputError("the program does not move the arm", field=("segments",))
    duration = offset
    regular = sample_times(duration, task.sample_period, task.samples, MAX_POINTS)
    marks = np.unique([t for _, _, ch in timings for p in ch for t in p.times])
    near = np.min(np.abs(regular[:, None] - marks[None, :]), axis=1) < _MIN_GAP
    times = np.union1d(regular[~near], marks)
    if len(times) > MAX_POINTS:
        raise TooLarge(
            f"the program needs {len(times)} points (the regular ones and {len(marks)} segment "
            f"and blend boundaries), over the limit of {MAX_POINTS}",
            field=("samples",) if task.samples is not None else ("sample_period",),
        )
    q, qd, qdd = _sample(timings, times)
    # Peaks of the analytic q(t) of every chunk (exact for joint profiles, dense for the rest),
    # never below the returned samples'.
    peaks = [timing.peaks() for _, timing, _ in timings]
    combined = Peaks(
        np.maximum(np.max([p.velocity for p in peaks], axis=0), np.abs(qd).max(axis=0)),
        np.maximum(np.max([p.acceleration for p in peaks], axis=0), np.abs(qdd).max(axis=0)),
        np.max([p.jerk for p in peaks], axis=0),
    )
    traj = Trajectory(times, q, qd, qdd, robot.joint_names, peaks=combined)
    spans = {(p.owner, p.blend): p.times for _, _, ch in timings for p in ch}

    def sampler(t: np.ndarray) -> np.ndarray:
        return _sample(timings, t)[0]

    result = report(task, lay, geo, spans, traj, sampler)
    planned = {sp.index for sp in geo.segments}
    ignored = tuple(
        f"segment {i}: profile {seg.profile!r} ignored: a PTP inside a blend follows the "
        "program's common timing (profiles apply to PTPs between stops)"
        for i, seg in enumerate(task.segments)
        if seg.profile is not None and i in planned and i not in profiled
    )
    if ignored:
        result = replace(result, warnings=result.warnings + ignored)
    for sr in result.segments:  # how each segment was timed
        if sr.index in timed_by:
            sr.diagnostics["timing"] = timed_by[sr.index]
    # How much the dense limit check stretched the time-optimal timing (1.0: not at all), and
    # how many rest-to-rest stretches the program has (stops + 1).
    result.diagnostics["stretch"] = max(timing.stretch for _, timing, _ in timings)
    result.diagnostics["stops"] = len(timings) - 1
    return result


def _sample(
    timings: list[tuple[float, ChunkTiming | ProfileTiming, list[_Piece]]], times: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities, accelerations at ``times``, exact (and at rest) at chunk ends."""
    starts = np.array([o for o, _, _ in timings])
    which = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(timings) - 1)
    dof = timings[0][2][0].q.shape[1]
    q, qd, qdd = (np.empty((len(times), dof)) for _ in range(3))
    for k, (offset, timing, chunk) in enumerate(timings):
        sel = which == k
        q[sel], qd[sel], qdd[sel] = timing.sample(times[sel] - offset)
        for t, value in ((offset, chunk[0].q[0]), (offset + timing.duration, chunk[-1].q[-1])):
            hit = np.flatnonzero(np.abs(times - t) < 1e-12)
            q[hit], qd[hit], qdd[hit] = value, 0.0, 0.0
    return q, qd, qdd


__all__ = ["ProgramResult", "SegmentResult", "plan_program"]
