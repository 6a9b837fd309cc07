"""Effort limits in a program: each chunk's torque within the limits, and the peak effort.

A chunk timed by the time-optimal law keeps the effort limits itself (they are rows of its
``PathLimits.rows``; ``OptimalLaw.keeps_effort``). Any other chunk (``jerk_limited``, ``s_curve``,
a PTP's joint profile) is checked densely (``core.joint.effort.effort_peak_ratio``) and, over a
limit, run uniformly slower until it holds (``shortest_for_effort``: the torque of the same motion
slowed by k is b / k^2 + g, so a longer time always helps unless gravity alone exceeds a limit).
Slowing a chunk later (``core.program.assemble.settled``) keeps the effort within its limits too
(the torque moves from b + g towards g).

A failure (gravity alone over a limit; no motion keeping every limit) names the joint, the
segment and ``s`` within that segment (``locate``). ``program_peak_effort`` is |tau| per joint over
the returned motion (its points and ``DENSE`` points between consecutive ones).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from core.errors import PlanningError
from core.joint.effort import (
    TOLERANCE,
    Sampled,
    TimeScaled,
    effort_peak_ratio,
    peak_effort,
    shortest_for_effort,
)
from core.kinematics import DEFAULT_GRAVITY
from core.program.chunk import ChunkTiming
from core.program.piece import Piece
from core.program.segments import ProgramTask
from core.trajectory import Trajectory


def held_effort(task: ProgramTask, timing: ChunkTiming) -> ChunkTiming:
    """``timing`` run slower where its torque exceeds ``task.effort`` (module docstring); a
    failure's ``s`` is the chunk's path fraction there."""
    effort = task.effort
    if effort is None or getattr(timing.law, "keeps_effort", False):
        return timing
    names = task.robot.joint_names
    duration = timing.duration

    def where(share: float) -> float:  # the path fraction at a share of the duration
        return float(timing.law(np.array([share * duration]))[0])

    if effort_peak_ratio(timing, effort, names, where) <= 1.0 + TOLERANCE:
        return timing
    slower = shortest_for_effort(
        lambda T: timing.slower(T / duration), duration, effort, names, task.deadline, where
    )
    return slower  # type: ignore[return-value]


def held_profile_effort(task: ProgramTask, profile: Sampled, names: Sequence[str]) -> Sampled:
    """A PTP's joint profile (rest to rest) slowed until its torque keeps ``task.effort``; a
    failure's ``s`` is the share of the joint segment there."""
    effort = task.effort
    if effort is None:
        return profile
    duration = float(profile.duration)

    def where(share: float) -> float:  # s(t) of the straight move: its share of the segment
        law = getattr(profile, "law", None)
        return share if law is None else float(np.ravel(law(np.array([share * duration])))[0])

    if effort_peak_ratio(profile, effort, names, where) <= 1.0 + TOLERANCE:
        return profile
    return shortest_for_effort(
        lambda T: TimeScaled(profile, T),  # type: ignore[arg-type]
        duration,
        effort,
        names,
        task.deadline,
        where,
    )


def locate(err: PlanningError, chunk: list[Piece], spots: list[np.ndarray]) -> None:
    """Name the segment of ``err`` (``extra["segment"]``) and turn its ``s``, a path fraction of
    the chunk, into the path parameter of that segment (a blend: its segment's end, 1);
    ``spots``: each piece's samples' chunk fractions."""
    if err.s is None:
        err.extra.setdefault("segment", chunk[0].owner)
        return
    s = float(err.s)
    owner, share = chunk[-1].owner, 1.0
    for p, at in zip(chunk, spots, strict=True):
        if s <= at[-1] + 1e-12:
            owner = p.owner
            share = 1.0 if p.s is None else float(np.interp(s, at, p.s))
            break
    said = f"s={s:.6g}"
    where = f"s={share:.6g} of segment {owner}"
    err.detail = (
        err.detail.replace(said, where) if said in err.detail else f"{err.detail} ({where})"
    )
    err.args = (err.detail,)
    err.extra["segment"] = owner
    err.s = share


def program_peak_effort(
    task: ProgramTask, motion: Sampled, trajectory: Trajectory
) -> np.ndarray | None:
    """Largest |tau| [N m or N] per joint at the returned points (their own q, q', q'': at rest at
    a chunk's ends) and over ``motion`` between them (None without dynamics)."""
    between = peak_effort(task.dynamics, motion, trajectory.times, task.gravity)
    if between is None or task.dynamics is None:
        return None
    tr = trajectory
    gravity = np.asarray(DEFAULT_GRAVITY if task.gravity is None else task.gravity, dtype=float)
    at = task.dynamics.inverse_dynamics(tr.positions, tr.velocities, tr.accelerations, gravity)
    return np.maximum(between, np.abs(at).max(axis=0))


def rest_effort(task: ProgramTask, q: np.ndarray) -> np.ndarray | None:
    """|tau| [N m or N] per joint holding ``q`` ``(dof,)`` at rest (gravity alone; None without
    dynamics)."""
    if task.dynamics is None:
        return None
    gravity = np.asarray(DEFAULT_GRAVITY if task.gravity is None else task.gravity, dtype=float)
    q = np.asarray(q, dtype=float)[None]
    zero = np.zeros_like(q)
    return np.abs(task.dynamics.inverse_dynamics(q, zero, zero, gravity))[0]
