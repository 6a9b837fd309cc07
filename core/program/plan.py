"""A motion program as one trajectory: the one pipeline of ``POST /v1/trajectories/program``.

    layout -> check start -> build (segments, blends) -> time chunks -> assemble -> collide

The joint path is cut into chunks at every stop (an unblended segment goal); blended corners stay
inside a chunk. Each chunk is timed as one rest-to-rest motion (``core.program.timing``; an
S-curve when one of its LIN/CIRC segments asks for ``speed_profile="s_curve"``), so the program
stops exactly at unblended goals and nowhere else. A chunk that is a lone PTP with a ``profile``
is timed by that joint profile instead, synchronously (``core.program.ptp``: every joint follows
one law s(t), so the joint path stays the straight segment; trapezoidal, quintic, or jerk_limited
on Ruckig), under the joint limits times the segment's scales (``core.program.timed``). The
timed chunks are sampled and reported (``core.program.assemble``) and the whole motion is checked
for collisions, stopping before a contact with ``allow_partial`` (``core.program.stop``).
"""

from __future__ import annotations

from core.program.assemble import assemble, settled
from core.program.report import ProgramResult, SegmentResult
from core.program.segments import ProgramTask
from core.program.stop import collide
from core.program.timed import timed_program


def plan_program(task: ProgramTask) -> ProgramResult:
    """Plan ``task`` (see the module docstring)."""
    timed = settled(timed_program(task))
    return collide(timed, assemble(timed))


__all__ = ["ProgramResult", "SegmentResult", "plan_program"]
