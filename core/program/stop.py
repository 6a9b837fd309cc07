"""The collision stage of a motion program: check the whole motion, then stop before a contact.

``collide`` runs ``core.collisions`` on the assembled program: the continuous check of every
returned segment. A contact names its ``segment`` (the one whose window, its own part or its blend
out, holds the contact time) and ``s`` within it (``timed.segment_share``: the closest point of
its line or arc, or the projection on a PTP's joint segment). With ``allow_partial`` the program
stops before it: cut at the last clear returned point and brought to rest there along its own path
(``assemble.rest_at``), checked again, earlier by ``STOP_SHRINK`` of the time while that stop is
not clear (``STOP_TRIES`` in all); when none is clear (or the time budget is spent), the answer is
the returned points before the contact, ending in motion (``MOVING_END``), its segment windows cut
with it.
"""

from __future__ import annotations

from dataclasses import replace

from core.collisions import (
    MOVING_END,
    STOP_SHRINK,
    STOP_TRIES,
    ContactFound,
    End,
    check_ends,
    check_motion,
    collision_error,
    cut_before,
)
from core.errors import Collision, PlanningError
from core.kinematics import Clearance
from core.program.assemble import rest_at
from core.program.report import ProgramResult, SegmentResult
from core.program.timed import TimedProgram, segment_share


def segment_at(segments: tuple[SegmentResult, ...], t: float) -> SegmentResult | None:
    """The segment whose window (own part or blend out) holds time ``t`` [s]: the last moving one
    that starts at or before ``t``."""
    moving = [s for s in segments if s.end_time > s.start_time or s.blend_out is not None]
    before = [s for s in moving if s.start_time <= t + 1e-12]
    return before[-1] if before else (moving[0] if moving else None)


def collide(timed: TimedProgram, result: ProgramResult) -> ProgramResult:
    """``result`` checked for collisions (see the module docstring)."""
    clearance = timed.task.collision_check
    if clearance is None:
        return result
    traj = result.trajectory
    if result.failure is None and result.segments:
        last = result.segments[-1].index
        goal = End("goal", traj.positions[-1], float(traj.times[-1]), 1.0, last)
        check_ends(clearance, (goal,))
    found = check_motion(traj, clearance)
    if found.contact is None:
        return replace(result, clearance=found.report)
    failure = _failure(timed, result, found.contact)
    if not timed.task.allow_partial:
        raise failure
    return _stop_before(timed, result, found.contact, failure, clearance)


def _failure(timed: TimedProgram, result: ProgramResult, contact: ContactFound) -> Collision:
    seg = segment_at(result.segments, contact.time)
    if seg is None:
        return collision_error(contact)
    share = segment_share(timed, seg.index, contact.q)
    return collision_error(contact, s=share, segment=seg.index)


def _stop_before(
    timed: TimedProgram,
    result: ProgramResult,
    contact: ContactFound,
    failure: Collision,
    clearance: Clearance,
) -> ProgramResult:
    t = float(result.trajectory.times[contact.index])
    for _ in range(STOP_TRIES):
        try:
            stopped = rest_at(timed, t, failure)
        except PlanningError:  # the time budget, an S-curve Ruckig refuses: keep the cut
            break
        if stopped is None:
            break
        found = check_motion(stopped.trajectory, clearance)
        if found.contact is None:
            return replace(stopped, clearance=found.report)
        t *= STOP_SHRINK
    return _moving_cut(timed, result, contact, failure, clearance)


def _moving_cut(
    timed: TimedProgram,
    result: ProgramResult,
    contact: ContactFound,
    failure: Collision,
    clearance: Clearance,
) -> ProgramResult:
    """The returned points before ``contact``, ending in motion, the segments' windows cut at the
    last one; ``fraction``: the segments done plus the share of the last one."""
    traj = cut_before(result.trajectory, contact)
    last = float(traj.times[-1])
    kept = tuple(_clipped(s, last) for s in result.segments if s.start_time < last or s.index == 0)
    seg_last = segment_at(result.segments, last)
    done = 0.0
    if seg_last is not None:
        share = segment_share(timed, seg_last.index, traj.positions[-1])
        done = (seg_last.index + share) / max(len(result.segments), 1)
    fraction = min(float(result.fraction), done)
    return replace(
        result,
        trajectory=traj,
        segments=kept,
        warnings=(
            f"planned {fraction:.1%} of the program: {failure.detail}",
            *result.warnings,
            MOVING_END,
        ),
        fraction=fraction,
        failure=failure,
        clearance=check_motion(traj, clearance).report,
    )


def _clipped(segment: SegmentResult, last: float) -> SegmentResult:
    """A segment's windows cut at ``last`` [s], the end of a partial answer (its blend out
    dropped when it had not begun by then, else ended there)."""
    if segment.end_time <= last and (segment.blend_out is None or segment.blend_out[1] <= last):
        return segment
    blend = segment.blend_out
    if blend is not None:
        blend = None if blend[0] >= last else (blend[0], last)
    return replace(segment, end_time=min(segment.end_time, last), blend_out=blend)


__all__ = ["collide", "segment_at"]
