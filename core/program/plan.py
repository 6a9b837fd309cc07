"""A motion program as one trajectory: the one pipeline of ``POST /v1/trajectories/program``.

    layout -> check start -> build (segments, blends) -> time chunks -> settle -> assemble
    -> collide

The joint path is cut into chunks at every stop (an unblended segment goal); blended corners stay
inside a chunk. Each chunk is a ``JointPath`` timed as one rest-to-rest motion by a law of
``core.timing.TIMING_LAWS`` (``core.program.pieces``: the program's ``timing``, or the
``speed_profile`` its LIN/CIRC segments ask for), so the program stops exactly at unblended goals
and nowhere else. A chunk that is a lone PTP with a ``profile`` is timed by that joint profile
instead, synchronously (``core.joint.synchronous``), under the joint limits times the segment's
scales (``core.program.timed``). The timed chunks are returned as what their points describe
(``core.program.returned``), slowed where that overshoots a limit, sampled and reported
(``core.program.assemble``), and the whole motion is checked for collisions, stopping before a
contact with ``allow_partial`` (``core.program.stop``).
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
