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
S-curve's phases: its jerk is the limited quantity, which the spline would not keep), are returned
as their own exact samples, with every switch a returned point: between two points a trapezoid's
acceleration is constant, a jerk-limited profile's linear.

``ChunkMotion.ratios`` compares the returned motion with the chunk's limits, so the program can
stretch a chunk whose spline overshoots them (``core.program.assemble``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from core.program.chunk import ChunkTiming
from core.program.pieces import Piece, ProfileTiming
from core.trajectory import Peaks


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


def chunk_motion(
    offset: float, timing: ChunkTiming | ProfileTiming, times: np.ndarray
) -> ChunkMotion:
    """The returned motion of a chunk at program times ``times`` (its ends included) (see the
    module docstring)."""
    tau = np.asarray(times, dtype=float) - offset
    tau[0], tau[-1] = 0.0, timing.duration
    if isinstance(timing, ProfileTiming) or len(timing.switch_times()):
        q, qd, qdd = timing.sample(tau)
        q[[0, -1]] = timing.ends()
        qd[[0, -1]], qdd[[0, -1]] = 0.0, 0.0  # at rest at both ends (a trapezoid's ramps step)
        return ChunkMotion(offset, tau + offset, q, qd, qdd, timing.peaks(), None, timing)
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
