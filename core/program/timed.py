"""The program timed: every rest-to-rest stretch (chunk) of its joint path with its timing.

``timed_program`` checks the program (``core.program.validate.layout``), checks the start and
every goal given as joints for collisions, builds the joint path across segments and blends
(``core.program.build``), cuts it at every stop into chunks (``core.program.pieces``) and times
each chunk rest to rest, placing it after the previous one. ``TimedProgram`` is what the later
stages need (sampling and the report, ``core.program.assemble``; stopping before a contact,
``core.program.stop``): a value inside core, never part of a result.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core.collisions import End, check_ends
from core.program.build import Geometry, build
from core.program.chunk import ChunkTiming
from core.program.pieces import (
    Piece,
    ProfileTiming,
    chunk_law,
    chunks_of,
    profile_kind,
    time_pieces,
)
from core.program.segments import ProgramTask
from core.program.validate import Layout, layout

Timed = tuple[float, ChunkTiming | ProfileTiming, list[Piece]]
"""A timed chunk: its start [s] in the program, its timing, its pieces (times in the program)."""


@dataclass(frozen=True)
class TimedProgram:
    """The program's geometry and timed chunks.

    Attributes:
        task: The program.
        lay: What its entry checks found (goals, lengths, blends, skipped segments).
        geo: Its joint path across segments and blends.
        timings: The timed chunks in order (``Timed``: start [s], timing, pieces).
        profiled: Segments timed by their PTP ``profile``.
        timed_by: Segment index -> the timing that timed it (a ``TIMING_LAWS`` name for the
            stretches between stops, or a PTP's joint profile).
    """

    task: ProgramTask
    lay: Layout
    geo: Geometry
    timings: tuple[Timed, ...]
    profiled: frozenset[int]
    timed_by: dict[int, str]

    @property
    def duration(self) -> float:
        """[s] of the whole program (0: it does not move)."""
        if not self.timings:
            return 0.0
        offset, timing, _ = self.timings[-1]
        return offset + timing.duration


def check_start(task: ProgramTask) -> None:
    """Before planning: the start and every goal given as joints must be clear (``Collision``)."""
    ends = [End("start", task.q_start, 0.0, 0.0, 0)]
    for i, seg in enumerate(task.segments):
        if seg.goal_positions is not None:
            ends.append(End("goal", seg.goal_positions, None, 1.0, i))
    check_ends(task.collision_check, tuple(ends))


def timed_program(task: ProgramTask) -> TimedProgram:
    """Check, build and time ``task`` (see the module docstring); a program that moves no joint
    has no timings."""
    lay = layout(task)
    check_start(task)
    geo = build(task, lay)
    timings: list[Timed] = []
    offset = 0.0
    profiled: set[int] = set()
    timed_by: dict[int, str] = {}
    for chunk in chunks_of(task, geo):
        task.deadline.check("timing the program")
        timing = time_pieces(task, chunk)
        kind = profile_kind(task, chunk)
        if kind is not None:
            profiled.add(chunk[0].owner)
        for p in chunk:
            if not p.blend:
                timed_by[p.owner] = kind or chunk_law(task, chunk)
        if timing is None:
            continue
        timings.append(placed(offset, timing, chunk))
        offset += timing.duration
    return TimedProgram(task, lay, geo, tuple(timings), frozenset(profiled), timed_by)


def placed(offset: float, timing: ChunkTiming | ProfileTiming, chunk: list[Piece]) -> Timed:
    """The chunk placed at ``offset`` [s]: its pieces' times moved into the program's."""
    for p in chunk:
        p.times = (p.times[0] + offset, p.times[1] + offset)
    return offset, timing, chunk


def segment_share(timed: TimedProgram, index: int, q: np.ndarray) -> float:
    """The path parameter in [0, 1] of segment ``index`` at configuration ``q`` ``(dof,)``: the
    closest point of its line or arc to the tool pose there (``Path.deviation``), or for a PTP the
    projection on its joint segment."""
    sp = next(p for p in timed.geo.segments if p.index == index)
    seg = sp.seg
    if sp.path is not None:
        pose = timed.task.robot.fk(np.asarray(q, dtype=float))[None]
        dev = sp.path.deviation(pose, seg.position_tolerance, seg.orientation_tolerance)
        return float(dev.s[0])
    if sp.joint_path is not None:  # a planned PTP: its nearest sample
        return float(sp.s[int(np.argmin(np.linalg.norm(sp.q - q, axis=1)))])
    d = sp.q[-1] - sp.q[0]
    dd = float(d @ d)
    return 0.0 if dd == 0.0 else float(np.clip((q - sp.q[0]) @ d / dd, 0.0, 1.0))


def restretched(timed: TimedProgram, factors: dict[int, float]) -> TimedProgram:
    """``timed`` with chunk ``k`` run ``factors[k]`` (> 1) times slower (its path unchanged), the
    chunks after it moved later: new pieces with the new times."""
    timings: list[Timed] = []
    offset = 0.0
    for k, (old_offset, timing, chunk) in enumerate(timed.timings):
        f = factors.get(k, 1.0)
        if f != 1.0 and isinstance(timing, ChunkTiming):
            timing = timing.slower(f)
        else:
            f = 1.0
        pieces = [
            replace(
                p,
                times=(
                    offset + f * (p.times[0] - old_offset),
                    offset + f * (p.times[1] - old_offset),
                ),
                knots=None if p.knots is None else f * p.knots,
            )
            for p in chunk
        ]
        timings.append((offset, timing, pieces))
        offset += timing.duration
    return replace(timed, timings=tuple(timings))
