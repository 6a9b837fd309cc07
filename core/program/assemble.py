"""A timed program sampled and reported (``assemble``), or cut and brought to rest (``rest_at``).

The returned points are a regular grid (``sample_period`` or ``samples``) plus every segment
boundary and blend window boundary, so a controller reaches each goal exactly. LIN/CIRC deviation
from their line/arc is measured outside the blend windows along the returned trajectory
(``core.program.report``). The trajectory's peaks (``peak_jerk`` included) are those of the
analytic q(t) of every chunk.

``rest_at(timed, t, failure)`` is the same program cut at time t and brought to rest there: the
chunks before unchanged, the one holding t re-timed rest to rest along its own joint path up to
the position at t (``allow_partial`` when a collision is ahead, ``core.program.stop``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from core.errors import PlanningError, TooLarge
from core.program.chunk import ChunkTiming
from core.program.pieces import Piece, ProfileTiming, time_pieces
from core.program.report import ProgramResult, report
from core.program.timed import Timed, TimedProgram, placed
from core.trajectory import MAX_POINTS, Peaks, Trajectory, sample_times

MIN_GAP = 1e-6
"""Regular sample times closer than this [s] to a boundary time are dropped (the boundary stays)."""


def assemble(timed: TimedProgram) -> ProgramResult:
    """Sample the timed chunks and report them (``core.program.report``)."""
    task, timings = timed.task, timed.timings
    duration = timed.duration
    regular = sample_times(duration, task.sample_period, task.samples, MAX_POINTS)
    marks = np.unique([t for _, _, ch in timings for p in ch for t in p.times])
    near = np.min(np.abs(regular[:, None] - marks[None, :]), axis=1) < MIN_GAP
    times = np.union1d(regular[~near], marks)
    if len(times) > MAX_POINTS:
        raise TooLarge(
            f"the program needs {len(times)} points (the regular ones and {len(marks)} segment "
            f"and blend boundaries), over the limit of {MAX_POINTS}",
            field=("samples",) if task.samples is not None else ("sample_period",),
        )
    q, qd, qdd = sample(timings, times)
    # Peaks of the analytic q(t) of every chunk (exact for joint profiles, dense for the rest),
    # never below the returned samples'.
    peaks = [timing.peaks() for _, timing, _ in timings]
    combined = Peaks(
        np.maximum(np.max([p.velocity for p in peaks], axis=0), np.abs(qd).max(axis=0)),
        np.maximum(np.max([p.acceleration for p in peaks], axis=0), np.abs(qdd).max(axis=0)),
        np.max([p.jerk for p in peaks], axis=0),
    )
    traj = Trajectory(times, q, qd, qdd, task.robot.joint_names, peaks=combined)
    spans = {(p.owner, p.blend): p.times for _, _, ch in timings for p in ch}

    def positions(t: np.ndarray) -> np.ndarray:
        return sample(timings, t)[0]

    result = report(task, timed.lay, timed.geo, spans, traj, positions)
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
    # How much the dense limit check stretched the time-optimal timing (1.0: not at all), and
    # how many rest-to-rest stretches the program has (stops + 1).
    result.diagnostics["stretch"] = max(timing.stretch for _, timing, _ in timings)
    result.diagnostics["stops"] = len(timings) - 1
    return result


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
    result = assemble(replace(timed, task=short, geo=geo, timings=tuple(kept)))
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
