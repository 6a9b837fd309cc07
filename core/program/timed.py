"""The program timed: every rest-to-rest stretch (chunk) of its joint path with its timing.

``timed_program`` checks the program (``core.program.validate.layout``), checks the start and
every goal given as joints for collisions, builds the joint path across segments and blends
(``core.program.build``), cuts it at every stop into chunks (``core.program.pieces``) and times
each chunk rest to rest, placing it after the previous one. ``TimedProgram`` is what the later
stages need (sampling and the report, ``core.program.assemble``; stopping before a contact,
``core.program.stop``): a value inside core, never part of a result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.collisions import End, check_ends
from core.errors import InputError
from core.program.build import Geometry, build
from core.program.chunk import ChunkTiming
from core.program.pieces import Piece, ProfileTiming, chunks_of, profile_kind, time_pieces
from core.program.s_curve import ShapedSCurve
from core.program.segments import ProgramTask
from core.program.validate import Layout, layout
from core.timing.s_curve import SCurveTiming

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
        timed_by: Segment index -> the timing that timed it (``time_optimal``, ``s_curve`` or a
            joint profile's name).
    """

    task: ProgramTask
    lay: Layout
    geo: Geometry
    timings: tuple[Timed, ...]
    profiled: frozenset[int]
    timed_by: dict[int, str]

    @property
    def duration(self) -> float:
        """[s] of the whole program."""
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
    """Check, build and time ``task`` (see the module docstring)."""
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
        elif timing is not None:
            kind = (
                "s_curve" if isinstance(timing.law, SCurveTiming | ShapedSCurve) else "time_optimal"
            )
        for p in chunk:
            if not p.blend:
                timed_by[p.owner] = kind or "time_optimal"
        if timing is None:
            continue
        timings.append(placed(offset, timing, chunk))
        offset += timing.duration
    if not timings:
        raise InputError("the program does not move the arm", field=("segments",))
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
    d = sp.q[-1] - sp.q[0]
    dd = float(d @ d)
    return 0.0 if dd == 0.0 else float(np.clip((q - sp.q[0]) @ d / dd, 0.0, 1.0))
