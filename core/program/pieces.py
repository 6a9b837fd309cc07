"""A program's joint path as chunks of pieces (segments' own parts and blends), and their timing.

The path is cut into chunks at every stop (an unblended segment goal); a chunk is a list of
``Piece``s (a segment's own part, or a blend) that share their junction samples. ``time_pieces``
times one chunk rest to rest: its joint path (``core.program.chunk.ChunkPath``) under its
``PathLimits`` (each sample's joint limits times its segment's scales, its tool speed and
acceleration limits, the tool's rate from the Jacobian) by a law of ``core.timing.TIMING_LAWS``:
the ``speed_profile`` its LIN/CIRC segments ask for when one asks for another than the default
(``s_curve``), else the program's ``timing``. A lone unblended PTP with a ``profile`` is timed by
that joint profile instead, along its joint segment (``core.joint.synchronous``). Each piece
records when it and each of its samples is reached. Units: [rad or m], [s].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import Infeasible, InputError, PlanningError
from core.joint.synchronous import straight_ptp
from core.limits import JointLimits
from core.program.build import Geometry
from core.program.chunk import ChunkPath, ChunkTiming
from core.program.chunk_limits import chunk_limits
from core.program.effort import held_effort, held_profile_effort, locate
from core.program.piece import Piece
from core.program.segments import ProgramTask
from core.timing import DEFAULT_LAW, TIMING_LAWS, TimingSpec
from core.trajectory import Peaks, Profile

__all__ = ["Piece", "ProfileTiming", "chunks_of", "profile_kind", "time_pieces"]

STOPPING_LAWS = frozenset({"time_optimal"})
"""Laws that stop where a chunk's path turns back (``ChunkPath`` with ``reversals``); the others
(a quintic spline s(t) through a grid) pass through the spline's tight turn there."""


def chunks_of(task: ProgramTask, geo: Geometry) -> list[list[Piece]]:
    """The geometry as chunks (lists of pieces between stops)."""
    robot = task.robot
    chunks: list[list[Piece]] = [[]]
    for sp in geo.segments:
        seg = sp.seg
        s, q = sp.piece()
        scales = (seg.velocity_scale, seg.acceleration_scale)
        piece = Piece(sp.index, False, q, robot.fk_many(q), scales, seg.tool_speeds(),
                      seg.tool_accelerations(), s)  # fmt: skip
        chunks[-1].append(piece)
        blend = geo.blends.get(sp.index)
        if blend is None:
            chunks.append([])
            continue
        nxt = next(p for p in geo.segments if p.index > sp.index).seg
        chunks[-1].append(
            Piece(
                sp.index,
                True,
                blend.q,
                blend.T,
                (
                    min(seg.velocity_scale, nxt.velocity_scale),
                    min(seg.acceleration_scale, nxt.acceleration_scale),
                ),
                _lowest(seg.tool_speeds(), nxt.tool_speeds()),
                _lowest(seg.tool_accelerations(), nxt.tool_accelerations()),
            )
        )
    return [c for c in chunks if c]


def _lowest(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    return (min(a[0], b[0]), min(a[1], b[1]))


def chunk_law(task: ProgramTask, chunk: list[Piece]) -> str:
    """The ``TIMING_LAWS`` name of a chunk (see the module docstring)."""
    asked = [
        task.segments[p.owner].speed_profile
        for p in chunk
        if not p.blend and task.segments[p.owner].cartesian
    ]
    other = [name for name in asked if name != DEFAULT_LAW]
    return other[0] if other else task.timing


def _time(task: ProgramTask, chunk: list[Piece]) -> ChunkTiming | None:
    """Time one chunk; record each piece's (start, end) time and sample times in the chunk. None
    if it is still."""
    qs: list[np.ndarray] = []
    starts: list[int] = []
    for k, p in enumerate(chunk):
        first = 0 if k == 0 else 1  # pieces share their junction sample
        starts.append(sum(len(x) for x in qs) - first)
        qs.append(p.q[first:])
    q = np.concatenate(qs)
    ends = [*starts[1:], len(q) - 1]
    step = np.linalg.norm(np.diff(q, axis=0), axis=1)
    if step.sum() < 1e-12:
        return None
    keep = np.concatenate([[True], step > 1e-13])
    index = np.cumsum(keep) - 1  # old sample -> kept sample
    name = chunk_law(task, chunk)
    # a law that keeps its limits at every instant stops where the path turns back
    path = ChunkPath(q[keep], junctions=index[starts[1:]], reversals=name in STOPPING_LAWS)
    spots = [path.knots[index[a : b + 1]] for a, b in zip(starts, ends, strict=True)]
    law = TIMING_LAWS[name]
    spec = TimingSpec(
        path=path,
        limits=chunk_limits(task, chunk, path, keep, starts),
        joint_names=tuple(task.robot.joint_names),
        deadline=task.deadline,
    )
    try:
        timing = held_effort(task, ChunkTiming.of(path, law(spec), spec.limits))
    except PlanningError as err:
        locate(err, chunk, spots)
        raise
    for p, a, b in zip(chunk, starts, ends, strict=True):
        p.times = (float(timing.knot_times[index[a]]), float(timing.knot_times[index[b]]))
        p.knots = timing.knot_times[index[a : b + 1]]
    return timing


@dataclass(frozen=True)
class ProfileTiming:
    """A chunk that is one unblended PTP, timed by its joint profile (``core.joint.synchronous``):
    rest to rest along the joint segment, sampled exactly (``sample`` as ``ChunkTiming.sample``).

    Attributes:
        profile: The straight-line profile (``StraightProfile``), t in [0, duration] [s].
        duration: Its length [s].
        stretch: 1.0 (the profile is timed within the limits by construction).
    """

    profile: Profile
    duration: float
    stretch: float = 1.0

    def peaks(self) -> Peaks:
        """The profile's exact peaks."""
        return self.profile.peaks()

    def switch_times(self) -> np.ndarray:
        """The profile's switch times [s] (a trapezoid's ramp ends, Ruckig's phases)."""
        return self.profile.switch_times()

    def ends(self) -> np.ndarray:
        """``(2, dof)``: the start and goal joint positions, exactly."""
        return np.asarray(self.profile.sample(np.array([0.0, self.duration]))[0])

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations (N, dof) at times ``t`` (N,) [s]."""
        return self.profile.sample(np.clip(np.asarray(t, dtype=float), 0.0, self.duration))


def profile_kind(task: ProgramTask, chunk: list[Piece]) -> str | None:
    """The joint profile a chunk is timed with: a lone PTP piece (rest to rest) that asks for one."""
    if len(chunk) != 1 or chunk[0].blend:
        return None
    seg = task.segments[chunk[0].owner]
    return seg.profile if seg.type == "ptp" else None


def _profile_time(task: ProgramTask, chunk: list[Piece], kind: str) -> ProfileTiming | None:
    """Time a lone PTP with joint profile ``kind`` under its scaled limits; None if it is still."""
    robot, p = task.robot, chunk[0]
    seg = task.segments[p.owner]
    q0, q1 = p.q[0], p.q[-1]
    if np.abs(q1 - q0).max() < 1e-12:
        return None
    limits = JointLimits(
        velocity=np.asarray(robot.velocity_limits, dtype=float) * seg.velocity_scale,
        acceleration=np.asarray(robot.acceleration_limits, dtype=float) * seg.acceleration_scale,
        jerk=robot.jerk_limits,
    )
    try:
        profile = straight_ptp(kind, q0, q1, limits, task.deadline)
    except PlanningError as err:
        err.extra["segment"] = p.owner
        if isinstance(err, InputError):
            err.field = ("segments", p.owner, "profile")
        raise
    try:
        profile = held_profile_effort(task, profile, robot.joint_names)  # type: ignore[assignment]
    except PlanningError as err:
        err.extra["segment"] = p.owner
        raise
    p.times = (0.0, profile.duration)
    return ProfileTiming(profile, profile.duration)


def time_pieces(task: ProgramTask, chunk: list[Piece]) -> ChunkTiming | ProfileTiming | None:
    """Time ``chunk`` rest to rest (by its PTP's profile when ``profile_kind`` names one); each
    piece's ``times`` (and ``knots``) are set within the chunk. None if no joint moves."""
    kind = profile_kind(task, chunk)
    try:
        return _time(task, chunk) if kind is None else _profile_time(task, chunk, kind)
    except PlanningError as err:  # e.g. an S-curve over Ruckig's duration cap
        err.extra.setdefault("segment", chunk[0].owner)
        if err.extra.get("limit") == "effort" and err.field is None:
            err.field = ("limits", "effort")
        if isinstance(err, Infeasible) and err.field is None:  # too slow: the smallest scale
            err.field = _slowest(task, chunk)
        raise


def _slowest(task: ProgramTask, chunk: list[Piece]) -> tuple[str | int, ...]:
    """The field that slows ``chunk`` most: the smallest velocity or acceleration scale of its
    segments (an acceleration scale counts squared: time grows as 1/sqrt of it)."""
    best = np.inf
    field: tuple[str | int, ...] = ("segments", chunk[0].owner)
    for p in chunk:
        seg = task.segments[p.owner]
        for name, slowdown in (("velocity_scale", seg.velocity_scale),
                               ("acceleration_scale", np.sqrt(seg.acceleration_scale))):  # fmt: skip
            if slowdown < best:
                best, field = slowdown, ("segments", p.owner, name)
    return field
