"""Timing of one rest-to-rest stretch of a program (a chunk: segments joined by blends).

The chunk's joint path is given by dense samples ``q_k`` (IK along lines and arcs, joint lines,
blends). It is parameterized by its joint-space arc length (normalized to s in [0, 1]), so dq/ds
is continuous across pieces that meet with a continuous tangent. Then:

1. Time-optimal s(t) (``core.timing.speed_limited.GridTiming``, the phase-plane forward/backward pass)
   under, at each sample: |dq/ds| s' <= v_max (the segment's scaled joint velocity limits), half of
   each joint's acceleration limit for the curvature term |d2q/ds2| s'^2 (another cap on s') and
   half for |dq/ds| |s''|, and the tool's linear/angular speed and acceleration limits on LIN/CIRC
   samples. A sharp corner (large d2q/ds2) slows the motion; a shallow one barely.
2. A quintic spline s(t) through the timed grid (scipy ``make_interp_spline``, k = 5, zero s' and
   s'' at both ends) and the path q(s) as a C2 cubic spline through the samples: q(t) = q(s(t)) has
   q, q', q'' continuous everywhere, stays on the sampled path's geometry, and is at rest at the
   chunk's ends, so chunks join with continuous q'' too.
3. A dense check (``CHECKS_PER_INTERVAL`` per knot interval) of joint velocity and acceleration
   against the limits; over them, time is stretched uniformly by the smallest factor that holds
   (velocities scale by 1/k, accelerations by 1/k^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, CubicSpline, make_interp_spline

from core.geometry import so3
from core.timing.speed_limited import GridTiming

ACCELERATION_SHARE = 0.5
CHECKS_PER_INTERVAL = 10
CAP_MARGIN = 0.98
"""Caps are applied this much tightened: the spline through the timed samples may overshoot a bit."""
_TINY = 1e-12


@dataclass(frozen=True)
class ChunkInput:
    """Samples of a chunk's path.

    Attributes:
        q: Joint positions (K, dof).
        T: Tool poses (K, 4, 4).
        v_max: Joint velocity limits (K, dof) [rad/s] at each sample (scaled per segment).
        a_max: Joint acceleration limits (K, dof) [rad/s^2].
        tool_speed: Linear and angular tool speed limits (K, 2) [m/s, rad/s] (inf: none).
        tool_acceleration: Linear and angular tool acceleration limits (K, 2) (inf: none).
    """

    q: np.ndarray
    T: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray
    tool_speed: np.ndarray
    tool_acceleration: np.ndarray


@dataclass(frozen=True)
class ChunkTiming:
    """The timed chunk: ``sample(t)`` for t in [0, duration].

    Attributes:
        knot_times: Time [s] of each input sample (K,), from 0 to ``duration``.
        duration: Length of the chunk [s].
        stretch: Factor the time-optimal timing was stretched by after the dense check (>= 1).
        law: s(tau) in the unstretched time tau = t / stretch.
        path: q(s), a C2 cubic spline through the samples.
    """

    knot_times: np.ndarray
    duration: float
    stretch: float
    law: BSpline
    path: CubicSpline

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations (N, dof) at times ``t`` (N,) [s]."""
        return _evaluate(
            self.law, self.path, np.asarray(t, dtype=float) / self.stretch, self.stretch
        )


def _evaluate(
    law: BSpline, path: CubicSpline, tau: np.ndarray, k: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    tau = np.clip(tau, 0.0, law.t[-1])
    s = np.clip(law(tau), 0.0, 1.0)
    sd, sdd = law(tau, 1) / k, law(tau, 2) / k**2
    d1 = path(s, 1)
    return path(s), d1 * sd[:, None], path(s, 2) * (sd**2)[:, None] + d1 * sdd[:, None]


def _norm_rows(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=1)


def time_chunk(c: ChunkInput) -> ChunkTiming:
    """Time the chunk (see the module docstring). ``c.q`` needs two distinct samples or more."""
    q = c.q
    step = _norm_rows(np.diff(q, axis=0))
    lam = np.concatenate([[0.0], np.cumsum(step)])
    s = lam / lam[-1]
    path = CubicSpline(s, q)
    dq, d2q = path(s, 1), path(s, 2)
    ds = np.diff(s)
    # Tool speed per unit s: linear from a spline of positions, angular by finite differences.
    dp = _norm_rows(CubicSpline(s, c.T[:, :3, 3])(s, 1))
    rel = so3.log(c.T[1:, :3, :3] @ np.swapaxes(c.T[:-1, :3, :3], 1, 2))
    w_int = _norm_rows(rel) / ds
    dw = np.maximum(np.concatenate([w_int[:1], w_int]), np.concatenate([w_int, w_int[-1:]]))
    with np.errstate(divide="ignore", invalid="ignore"):
        caps = [
            np.min(np.where(np.abs(dq) > _TINY, c.v_max / np.abs(dq), np.inf), axis=1),
            np.min(
                np.where(
                    np.abs(d2q) > _TINY,
                    np.sqrt(ACCELERATION_SHARE * c.a_max / np.abs(d2q)),
                    np.inf,
                ),
                axis=1,
            ),
            np.where(dp > _TINY, c.tool_speed[:, 0] / dp, np.inf),
            np.where(dw > _TINY, c.tool_speed[:, 1] / dw, np.inf),
        ]
        acc = [
            np.min(
                np.where(
                    np.abs(dq) > _TINY, (1 - ACCELERATION_SHARE) * c.a_max / np.abs(dq), np.inf
                ),
                axis=1,
            ),
            np.where(dp > _TINY, c.tool_acceleration[:, 0] / dp, np.inf),
            np.where(dw > _TINY, c.tool_acceleration[:, 1] / dw, np.inf),
        ]
    cap = CAP_MARGIN * np.minimum.reduce(caps)
    acc_s = CAP_MARGIN * np.minimum.reduce(acc)
    acc_int = np.minimum(acc_s[:-1], acc_s[1:])
    acc_int = np.where(np.isfinite(acc_int), acc_int, 1e6)
    timing = GridTiming(s, np.minimum(cap, 1e9), acc_int)
    t = timing.t
    bc = ([(1, 0.0), (2, 0.0)], [(1, 0.0), (2, 0.0)])
    law = make_interp_spline(t, s, k=5, bc_type=bc)
    # Dense check of the limits between the knots.
    frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
    dense = (t[:-1, None] + np.diff(t)[:, None] * frac).ravel()
    _, vel, accel = _evaluate(law, path, dense)
    v_lim = np.repeat(np.minimum(c.v_max[:-1], c.v_max[1:]), CHECKS_PER_INTERVAL, axis=0)
    a_lim = np.repeat(np.minimum(c.a_max[:-1], c.a_max[1:]), CHECKS_PER_INTERVAL, axis=0)
    ratio_v = float(np.max(np.abs(vel) / v_lim))
    ratio_a = float(np.max(np.abs(accel) / a_lim))
    stretch = max(1.0, ratio_v, np.sqrt(ratio_a)) * (1.0 + 1e-9)
    stretch = 1.0 if stretch <= 1.0 + 2e-9 else stretch
    return ChunkTiming(
        knot_times=t * stretch,
        duration=float(t[-1] * stretch),
        stretch=stretch,
        law=law,
        path=path,
    )
