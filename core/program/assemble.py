"""A timed program sampled and reported (``assemble``), or cut and brought to rest (``rest_at``).

The returned points are a regular grid (``sample_period`` or ``samples``) plus every segment
boundary and blend window boundary, so a controller reaches each goal exactly, and every time a
chunk's timing switches (a step in acceleration or jerk: a trapezoid's ramp ends, an S-curve's
phases), so the motion between two returned points is smooth and the returned velocities are the
integral of the returned accelerations. LIN/CIRC deviation
from their line/arc is measured outside the blend windows along the returned trajectory
(``core.program.report``). The trajectory's peaks (``peak_jerk`` included) are those of the
analytic q(t) of every chunk.

``rest_at(timed, t, failure)`` is the same program cut at time t and brought to rest there: the
chunks before unchanged, the one holding t re-timed rest to rest along its own joint path up to
the position at t (``allow_partial`` when a collision is ahead, ``core.program.stop``).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from core.errors import Infeasible, PlanningError, TooLarge
from core.joint.effort import effort_stretch
from core.program.chunk import ChunkTiming
from core.program.effort import program_peak_effort, rest_effort
from core.program.pieces import Piece, ProfileTiming, time_pieces
from core.program.report import ProgramResult, SegmentResult, report
from core.program.returned import (
    SWITCH_GAP,
    ChunkMotion,
    ReturnedMotion,
    chunk_motion,
    switch_marks,
)
from core.program.timed import Timed, TimedProgram, placed, restretched
from core.timing.path_profile import stretch_for
from core.trajectory import (
    DEFAULT_SAMPLE_PERIOD,
    MAX_DURATION,
    MAX_POINTS,
    Peaks,
    Trajectory,
    sample_times,
)

MIN_GAP = 1e-6
"""Regular sample times closer than this [s] to a boundary time are dropped (the boundary stays)."""
NEAR_SHARE = 0.25
"""Regular points closer than this share of their spacing to a boundary or switch are dropped."""
SETTLE_ROUNDS = 4
"""Most rounds of slowing chunks whose returned motion overshoots a limit (``settled``)."""


def returned_times(timed: TimedProgram) -> np.ndarray:
    """The program's returned times [s]: the regular grid, every segment and blend boundary and
    every switch of a chunk's timing (``TooLarge`` over ``MAX_POINTS``)."""
    task, timings = timed.task, timed.timings
    if not timed.duration <= MAX_DURATION:
        raise Infeasible(
            f"the program would last {timed.duration:.4g} s, over the {MAX_DURATION:g} s bound of "
            "any trajectory: raise its speed and acceleration limits or scales",
            field=("segments",),
        )
    regular = sample_times(timed.duration, task.sample_period, task.samples, MAX_POINTS)
    bounds = [t for _, _, ch in timings for p in ch for t in p.times]
    switches = [offset + switch_marks(timing) for offset, timing, _ in timings]
    marks = np.unique(np.concatenate([bounds, *switches]))
    # a regular point much closer to a mark than the spacing goes (the mark stays): an interval
    # of microseconds between returned points makes the cubic through them ill-conditioned
    spacing = float(np.median(np.diff(regular))) if len(regular) > 1 else timed.duration
    gap = max(MIN_GAP, NEAR_SHARE * spacing)
    near = np.min(np.abs(regular[:, None] - marks[None, :]), axis=1) < gap
    times = np.union1d(regular[~near], marks)
    if len(times) + 2 * len(timings) > MAX_POINTS:
        raise TooLarge(
            f"the program needs {len(times)} points (the regular ones and {len(marks)} segment "
            f"and blend boundaries), over the limit of {MAX_POINTS}",
            field=("samples",) if task.samples is not None else ("sample_period",),
        )
    return times


def motions(timed: TimedProgram) -> list[ChunkMotion]:
    """The returned motion of every chunk (``core.program.returned``)."""
    times = returned_times(timed)
    out = []
    for offset, timing, _ in timed.timings:
        end = offset + timing.duration
        inner = times[(times > offset + SWITCH_GAP / 2) & (times < end - SWITCH_GAP / 2)]
        out.append(chunk_motion(offset, timing, np.concatenate([[offset], inner, [end]])))
    return out


def settled(timed: TimedProgram) -> TimedProgram:
    """``timed`` with every chunk whose returned motion (the cubic through its returned points)
    overshoots a joint velocity or acceleration limit, or an effort limit, run that much slower
    (velocity by 1/k, acceleration by 1/k^2; the torque without gravity by 1/k^2), until none
    does (``SETTLE_ROUNDS`` at most)."""
    if not timed.timings:
        return timed
    robot = timed.task.robot
    v_max = np.asarray(robot.velocity_limits, dtype=float)
    a_max = np.asarray(robot.acceleration_limits, dtype=float)
    for _ in range(SETTLE_ROUNDS):
        timed.task.deadline.check("settling the program's returned motion")
        factors = {}
        for k, motion in enumerate(motions(timed)):
            r_v, r_a = motion.ratios(v_max, a_max, timed.timings[k][2])
            f = stretch_for((r_v, r_a))
            if timed.task.effort is not None:
                f = max(f, effort_stretch(motion, timed.task.effort, motion.times))
            if f > 1.0:
                factors[k] = f
        if not factors:
            break
        timed = restretched(timed, factors)
    return timed


def assemble(timed: TimedProgram) -> ProgramResult:
    """Sample the timed chunks and report them (``core.program.report``); a program that moves no
    joint is at rest (``at_rest``)."""
    task, timings = timed.task, timed.timings
    if not timings:
        return at_rest(timed)
    chunks = motions(timed)
    keep = [np.ones(len(m.times), dtype=bool) for m in chunks]
    for k in range(1, len(chunks)):  # a chunk starts where (and when) the last one ended at rest
        keep[k][0] = False
    times, q, qd, qdd = (
        np.concatenate([getattr(m, name)[kept] for m, kept in zip(chunks, keep, strict=True)])
        for name in ("times", "q", "qd", "qdd")
    )
    peaks = Peaks(*(np.max([getattr(m.peaks, f) for m in chunks], axis=0) for f in Peaks._fields))
    traj = Trajectory(times, q, qd, qdd, task.robot.joint_names, peaks=peaks)
    spans = {(p.owner, p.blend): p.times for _, _, ch in timings for p in ch}
    motion = ReturnedMotion(chunks)
    result = report(task, timed.lay, timed.geo, spans, traj, motion.positions)
    planned = {sp.index for sp in timed.geo.segments}
    ignored = tuple(
        f"segment {i}: profile {seg.profile!r} ignored: a PTP inside a blend follows the "
        "program's common timing (profiles apply to PTPs between stops)"
        for i, seg in enumerate(task.segments)
        if seg.profile is not None and i in planned and i not in timed.profiled
    )
    if ignored:
        result = replace(result, warnings=result.warnings + ignored)
    for sr in result.segments:  # how each segment was timed
        if sr.index in timed.timed_by:
            sr.diagnostics["timing"] = timed.timed_by[sr.index]
    # How much the dense limit checks stretched the timing (1.0: not at all), and how many
    # rest-to-rest stretches the program has (stops + 1).
    result.diagnostics["stretch"] = max(timing.stretch for _, timing, _ in timings)
    result.diagnostics["stops"] = len(timings) - 1
    effort = program_peak_effort(task, motion, traj)
    if effort is not None:
        result.diagnostics["peak_effort"] = effort
    return result


STILL = (
    "every segment has zero length (no joint moves): the answer is the start, at rest for one "
    "sample period"
)
"""Warning of a program that does not move the arm (as Pilz answers a LIN to its own start)."""


def at_rest(timed: TimedProgram) -> ProgramResult:
    """The answer of a program that moves no joint: the start at rest for one sample period
    (``sample_period``, default 0.01 s; ``samples`` points over it), every segment skipped."""
    task = timed.task
    duration = task.sample_period or DEFAULT_SAMPLE_PERIOD
    times = sample_times(duration, task.sample_period, task.samples, MAX_POINTS)
    q = np.tile(np.asarray(task.q_start, dtype=float), (len(times), 1))
    still = np.zeros_like(q)
    dof = q.shape[1]
    peaks = Peaks(np.zeros(dof), np.zeros(dof), np.zeros(dof))
    traj = Trajectory(times, q, still, still.copy(), task.robot.joint_names, peaks=peaks)
    segments = tuple(
        SegmentResult(i, seg.type, 0.0, 0.0, None, {"skipped": True})
        for i, seg in enumerate(task.segments)
    )
    diagnostics: dict[str, Any] = {"max_position_deviation": 0.0, "max_orientation_deviation": 0.0,
                                   "min_singular_value": None, "stretch": 1.0, "stops": 0}  # fmt: skip
    effort = rest_effort(task, q[0])
    if effort is not None:
        diagnostics["peak_effort"] = effort
    return ProgramResult(traj, segments, (*timed.lay.warnings, STILL), 1.0, None, diagnostics)


def rest_at(timed: TimedProgram, t: float, failure: PlanningError) -> ProgramResult | None:
    """The program up to time ``t`` [s], at rest there (see the module docstring), with
    ``failure`` as its partial plan's; None when nothing before ``t`` moves."""
    task, timings = timed.task, timed.timings
    task.deadline.check("bringing the program to rest")
    starts = np.array([o for o, _, _ in timings])
    k = int(np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(timings) - 1))
    offset, timing, chunk = timings[k]
    tau = t - offset
    kept = list(timings[:k])
    share = 1.0  # of the path parameter of the last kept piece's segment
    if tau >= timing.duration - MIN_GAP:  # the whole chunk: it ends at rest
        kept.append(timings[k])
    elif tau > MIN_GAP:
        cut, share = _cut(timed, chunk, timing, tau)
        retimed = time_pieces(task, cut) if cut else None
        if retimed is None:
            share = 1.0
        else:
            kept.append(placed(offset, retimed, cut))
    if not kept:
        return None
    owner = kept[-1][2][-1].owner
    short = replace(task, segments=task.segments[: owner + 1])
    geo = replace(
        timed.geo,
        segments=tuple(sp for sp in timed.geo.segments if sp.index <= owner),
        failure=None,
    )
    result = assemble(settled(replace(timed, task=short, geo=geo, timings=tuple(kept))))
    fraction = (owner + share) / len(task.segments)
    return replace(
        result,
        fraction=fraction,
        failure=failure,
        warnings=(f"planned {fraction:.1%} of the program: {failure.detail}", *result.warnings),
    )


def _cut(
    timed: TimedProgram, chunk: list[Piece], timing: ChunkTiming | ProfileTiming, tau: float
) -> tuple[list[Piece], float]:
    """The chunk's pieces up to its time ``tau`` [s], the last ending at the position there (new
    pieces, not yet timed), and the share of its segment's path parameter reached."""
    robot = timed.task.robot
    offset = chunk[0].times[0]
    q_cut = timing.sample(np.array([tau]))[0][0]
    out: list[Piece] = []
    for p in chunk:
        fresh = replace(p, times=(0.0, 0.0), knots=None)
        if p.times[1] - offset <= tau:
            out.append(fresh)
            continue
        if p.knots is None:  # a profiled PTP: its straight segment
            keep = np.array([True] + [False] * (len(p.q) - 1))
        else:
            keep = p.knots < tau - 1e-12
        if keep.any():
            share = 1.0
            if p.s is not None:
                if p.knots is None:
                    d = p.q[-1] - p.q[0]
                    u = float(np.clip((q_cut - p.q[0]) @ d / (d @ d), 0.0, 1.0))
                    share = float(p.s[0] + u * (p.s[-1] - p.s[0]))
                else:
                    share = float(np.interp(tau, p.knots, p.s))
            out.append(
                replace(
                    fresh,
                    q=np.concatenate([p.q[keep], q_cut[None]]),
                    T=np.concatenate([p.T[keep], robot.fk(q_cut)[None]]),
                    s=None if p.s is None else np.append(p.s[keep], share),
                )
            )
            return out, share
        break
    return out, 1.0


def sample(
    timings: tuple[Timed, ...], times: np.ndarray
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
