"""The returned motion of a program chunk: what the points describe, exactly.

A client gets positions, velocities and accelerations at the returned points, and a controller
interpolates between them. So that the returned velocities and accelerations are the exact
derivatives of the returned motion, the motion of a chunk timed by a path law (``ChunkTiming``) is
returned as the C2 cubic spline in time through the positions of the timed motion q(s(t)) at the
returned times, at rest (zero velocity and acceleration) at both ends of the chunk: between two
returned points it is one cubic, its acceleration linear, so integrating the returned accelerations
between consecutive points gives the returned velocities exactly, and the jerk is constant
(``peak_jerk`` is exact). Four end conditions take two more coefficients than the points give: the
midpoints of the chunk's first and last intervals are returned points the spline places itself
(not interpolated). The spline's positions at the other points are those of the timed motion, so
segment goals and blend boundaries are reached exactly.

A lone PTP timed by a joint profile (``ProfileTiming``), and a chunk whose law switches (an
S-curve's phases: its jerk is the limited quantity, which the spline would not keep; the
time-optimal law's grid, where s'' steps), are returned as their own exact samples, with every
switch a returned point: between two points a trapezoid's acceleration is constant, a jerk-limited
profile's linear. Where the acceleration steps (at a switch, and where a chunk leaves or reaches
rest), two more points ``SWITCH_GAP`` before and after it hold the step between them, and the
path's spline knots (where the jerk steps) are returned points
too (``switch_marks``); an interval over
which the trapezoid rule of the returned accelerations misses the returned velocities by more than
``INTEGRAL_TOLERANCE`` is halved (``REFINE_ROUNDS`` times at most: the miss falls 8-fold a round),
so integrating the returned accelerations between consecutive points gives the returned
velocities. ``peak_jerk`` of such a chunk is then the finite difference of its returned
accelerations where that is larger than the motion's own (what a controller sees).

``ChunkMotion.ratios`` compares the returned motion with the chunk's limits, so the program can
stretch a chunk whose spline overshoots them (``core.program.assemble``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from core.program.chunk import ChunkTiming
from core.program.pieces import Piece, ProfileTiming
from core.trajectory import Peaks, sampled_peak_jerk

SWITCH_GAP = 1e-8
"""[s] Distance of the points on either side of a step of the acceleration from it."""
INTEGRAL_TOLERANCE = 1e-7
"""[rad/s] Largest miss of the trapezoid rule of the returned accelerations over an interval of
exactly sampled points (the contract's 1e-6 with room; the positions then follow the cubic of consecutive points to 1e-9)."""
REFINE_ROUNDS = 8
"""Most rounds of halving the intervals that miss it."""
STEP = 1e-5
"""[rad/s^2] A step of the acceleration smaller than this gets no points of its own about it (over
the regular spacing the trapezoid rule misses it by less than ``INTEGRAL_TOLERANCE``; the halving
takes care of the rest)."""


def rest(dof: int) -> tuple[list[tuple[int, np.ndarray]], list[tuple[int, np.ndarray]]]:
    """``bc_type`` of zero velocity and acceleration at both ends of a chunk of ``dof`` joints."""
    zero = np.zeros(dof)
    return [(1, zero), (2, zero)], [(1, zero), (2, zero)]


@dataclass(frozen=True)
class ChunkMotion:
    """A chunk's returned points and the motion between them.

    Attributes:
        offset: The chunk's start [s] in the program.
        times: ``(M,)`` returned times [s] in the program, from ``offset`` to its end.
        q, qd, qdd: ``(M, dof)`` positions, velocities, accelerations there.
        peaks: Exact peaks of the returned motion (the spline's; the profile's).
        spline: The cubic in chunk time (None: a profile chunk, ``timing`` sampled exactly).
        timing: The chunk's timing.
    """

    offset: float
    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    peaks: Peaks
    spline: BSpline | None
    timing: ChunkTiming | ProfileTiming

    def positions(self, t: np.ndarray) -> np.ndarray:
        """Positions ``(N, dof)`` of the returned motion at program times ``t`` in the chunk."""
        tau = np.clip(np.asarray(t, dtype=float) - self.offset, 0.0, self.timing.duration)
        if self.spline is None:
            return self.timing.sample(tau)[0]
        return np.asarray(self.spline(tau), dtype=float)

    @property
    def duration(self) -> float:
        """[s] of the chunk."""
        return float(self.timing.duration)

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations ``(N, dof)`` of the returned motion at program
        times ``t`` in the chunk."""
        tau = np.clip(np.asarray(t, dtype=float) - self.offset, 0.0, self.timing.duration)
        if self.spline is None:
            return self.timing.sample(tau)
        return tuple(np.asarray(self.spline(tau, nu), dtype=float) for nu in (0, 1, 2))  # type: ignore[return-value]

    def ratios(self, robot_velocity: np.ndarray, robot_acceleration: np.ndarray,
               pieces: list[Piece]) -> tuple[float, float]:  # fmt: skip
        """Largest |velocity| and |acceleration| of the returned points (and of the velocity
        between them, where the acceleration crosses zero) over the chunk's limits (the robot's
        times each piece's scales)."""
        scale_v, scale_a = _scales(self.times, pieces)
        v_lim, a_lim = robot_velocity * scale_v, robot_acceleration * scale_a
        r_v = float(np.max(np.abs(self.qd) / v_lim))
        r_a = float(np.max(np.abs(self.qdd) / a_lim))
        if self.spline is not None and len(self.times) > 1:
            h = np.diff(self.times)[:, None]
            a0, a1 = self.qdd[:-1], self.qdd[1:]
            j = (a1 - a0) / h
            with np.errstate(divide="ignore", invalid="ignore"):
                tau = np.where(j != 0.0, -a0 / j, -1.0)
            inside = (tau > 0.0) & (tau < h)
            vertex = np.where(inside, self.qd[:-1] + a0 * tau + 0.5 * j * tau**2, 0.0)
            lim = np.minimum(v_lim[:-1], v_lim[1:])
            r_v = max(r_v, float(np.max(np.abs(vertex) / lim)))
        return r_v, r_a


class ReturnedMotion:
    """The program's returned motion across its chunks (``ChunkMotion`` in order): ``duration``
    [s] and ``sample(t)`` at program times (a ``core.joint.effort.Sampled``)."""

    def __init__(self, chunks: list[ChunkMotion]) -> None:
        self.chunks = chunks
        self.starts = np.array([m.offset for m in chunks])
        self.duration = float(chunks[-1].times[-1])

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        which = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.chunks) - 1)
        dof = self.chunks[0].q.shape[1]
        out = [np.empty((len(t), dof)) for _ in range(3)]
        for k, m in enumerate(self.chunks):
            sel = which == k
            if sel.any():
                for o, v in zip(out, m.sample(t[sel]), strict=True):
                    o[sel] = v
        return out[0], out[1], out[2]

    def positions(self, t: np.ndarray) -> np.ndarray:
        """Positions ``(N, dof)`` at program times ``t``."""
        t = np.asarray(t, dtype=float)
        which = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.chunks) - 1)
        out = np.empty((len(t), self.chunks[0].q.shape[1]))
        for k, m in enumerate(self.chunks):
            sel = which == k
            out[sel] = m.positions(t[sel])
        return out


def _scales(times: np.ndarray, pieces: list[Piece]) -> tuple[np.ndarray, np.ndarray]:
    """``(M, 1)`` velocity and acceleration scales of the limits at ``times``: the smallest of
    the pieces whose window holds each time."""
    scale_v, scale_a = np.ones((len(times), 1)), np.ones((len(times), 1))
    first = True
    for p in pieces:
        inside = (times >= p.times[0] - 1e-12) & (times <= p.times[1] + 1e-12)
        if first:
            scale_v[:], scale_a[:] = p.scales[0], p.scales[1]
            first = False
        scale_v[inside, 0] = np.minimum(scale_v[inside, 0], p.scales[0])
        scale_a[inside, 0] = np.minimum(scale_a[inside, 0], p.scales[1])
    return scale_v, scale_a


def switch_marks(timing: ChunkTiming | ProfileTiming) -> np.ndarray:
    """Times [s] in the chunk that must be returned points: every switch of its timing and,
    where the acceleration steps by more than ``STEP``, a point ``SWITCH_GAP`` on either side of
    it (the chunk's start and end included: at rest there, moving off at once), whichever side's
    acceleration the point at the switch itself carries after rounding."""
    switch = np.asarray(timing.switch_times(), dtype=float)
    if isinstance(timing, ChunkTiming) and not len(switch):
        return switch  # returned as a spline: no step anywhere
    end = timing.duration
    at = np.concatenate([[0.0], switch, [end]])

    def jump(eps: float) -> np.ndarray:
        before = timing.sample(np.clip(at - eps, 0.0, end))[2]
        after = timing.sample(np.clip(at + eps, 0.0, end))[2]
        before[0], after[-1] = 0.0, 0.0  # at rest outside the chunk
        return np.abs(after - before).max(axis=1)

    # a step keeps its size as the points close in; a smooth change shrinks with them
    wide, narrow = jump(SWITCH_GAP), jump(0.1 * SWITCH_GAP)
    steps = (narrow > 0.5 * wide) & (wide > STEP)
    near = np.concatenate([at[steps] - SWITCH_GAP, at[steps] + SWITCH_GAP])
    # the path's spline knots: its third derivative (the motion's jerk) steps there
    knots = timing.knot_times[1:-1] if isinstance(timing, ChunkTiming) else np.zeros(0)
    return np.unique(np.concatenate([switch, knots, near[(near > 0.0) & (near < end)]]))


def chunk_motion(
    offset: float, timing: ChunkTiming | ProfileTiming, times: np.ndarray
) -> ChunkMotion:
    """The returned motion of a chunk at program times ``times`` (its ends included) (see the
    module docstring)."""
    tau = np.asarray(times, dtype=float) - offset
    tau[0], tau[-1] = 0.0, timing.duration
    if isinstance(timing, ProfileTiming) or len(timing.switch_times()):
        tau, q, qd, qdd = _exact(timing, tau)
        own = timing.peaks()
        # over the returned times themselves (a difference of 1e-8 s is rounded differently in
        # chunk time)
        jerk = (
            np.maximum(own.jerk, sampled_peak_jerk(tau + offset, qdd)) if len(tau) > 1 else own.jerk
        )
        peaks = Peaks(own.velocity, own.acceleration, jerk)
        return ChunkMotion(offset, tau + offset, q, qd, qdd, peaks, None, timing)
    end = timing.duration
    if len(tau) == 2:  # one interval: two inner points the spline places
        mids = np.array([end / 3.0, 2.0 * end / 3.0])
    else:
        mids = np.array([0.5 * (tau[0] + tau[1]), 0.5 * (tau[-2] + tau[-1])])
    knots = np.sort(np.concatenate([tau, mids]))
    data = timing.sample(tau)[0]
    t_knots = np.concatenate([[0.0] * 4, knots[1:-1], [end] * 4])
    spline = make_interp_spline(tau, data, k=3, t=t_knots, bc_type=rest(data.shape[1]))
    q, qd, qdd = (np.asarray(spline(knots, nu), dtype=float) for nu in (0, 1, 2))
    q[np.isin(knots, tau)] = data  # the timed motion's own positions, to the last bit
    q[[0, -1]] = timing.ends()
    qd[[0, -1]], qdd[[0, -1]] = 0.0, 0.0
    motion = ChunkMotion(offset, knots + offset, q, qd, qdd, _peaks(spline, knots), spline, timing)
    return motion


def _exact(
    timing: ChunkTiming | ProfileTiming, tau: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The exact samples at chunk times ``tau`` and at the midpoints the integral of the
    accelerations asks for (module docstring): times, positions, velocities, accelerations."""
    for round_ in range(REFINE_ROUNDS + 1):
        q, qd, qdd = timing.sample(tau)
        q[[0, -1]] = timing.ends()
        qd[[0, -1]], qdd[[0, -1]] = 0.0, 0.0  # at rest at both ends (a trapezoid's ramps step)
        h = np.diff(tau)
        miss = np.abs(np.diff(qd, axis=0) - 0.5 * (qdd[1:] + qdd[:-1]) * h[:, None]).max(axis=1)
        bad = (miss > INTEGRAL_TOLERANCE) & (h > 4.0 * SWITCH_GAP)
        if not bad.any() or round_ == REFINE_ROUNDS:
            break
        tau = np.sort(np.concatenate([tau, tau[:-1][bad] + 0.5 * h[bad]]))
    return tau, q, qd, qdd


def _peaks(spline: BSpline, knots: np.ndarray) -> Peaks:
    """Exact peaks of a cubic spline in time: velocity at the knots and where the acceleration
    crosses zero inside an interval; acceleration at the knots; the jerk of each piece."""
    h = np.diff(knots)[:, None]
    v, a = spline(knots, 1), spline(knots, 2)
    jerk = (a[1:] - a[:-1]) / h  # constant on each piece: the acceleration is linear
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(jerk != 0.0, -a[:-1] / jerk, -1.0)  # where the acceleration crosses zero
    inside = (tau > 0.0) & (tau < h)
    v_turn = np.where(inside, np.abs(v[:-1] + a[:-1] * tau + 0.5 * jerk * tau**2), 0.0)
    return Peaks(
        np.maximum(np.abs(v).max(axis=0), v_turn.max(axis=0)),
        np.abs(a).max(axis=0),
        np.abs(jerk).max(axis=0),
    )
