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

An S-curve chunk (``ChunkInput.jerk`` set, ``core.program.s_curve``) replaces steps 1-2 by an S-curve law
(continuous s'', bounded jerk of s): ``ShapedSCurve``, a ``core.timing.s_curve.SCurveTiming``
through a smooth speed shape of the caps (lowered where the dense check finds a limit exceeded,
a few rounds), or one ``SCurveTiming`` under the chunk's smallest caps, whichever is shorter; the
dense check adds the tool's linear jerk (jerk scales by 1/k^3).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline, make_interp_spline

from core.geometry import so3
from core.program.chunk import (
    ACCELERATION_SHARE,
    CAP_MARGIN,
    CHECKS_PER_INTERVAL,
    TINY,
    ChunkInput,
    ChunkTiming,
    evaluate,
    norm_rows,
)
from core.program.s_curve import s_curve_chunk
from core.timing.speed_limited import GridTiming

__all__ = ["ChunkInput", "ChunkTiming", "time_chunk"]


def time_chunk(c: ChunkInput) -> ChunkTiming:
    """Time the chunk (see the module docstring). ``c.q`` needs two distinct samples or more."""
    q = c.q
    step = norm_rows(np.diff(q, axis=0))
    lam = np.concatenate([[0.0], np.cumsum(step)])
    s = lam / lam[-1]
    path = CubicSpline(s, q)
    dq, d2q = path(s, 1), path(s, 2)
    ds = np.diff(s)
    # Tool speed per unit s: linear from a spline of positions, angular by finite differences.
    dp = norm_rows(CubicSpline(s, c.T[:, :3, 3])(s, 1))
    rel = so3.log(c.T[1:, :3, :3] @ np.swapaxes(c.T[:-1, :3, :3], 1, 2))
    w_int = norm_rows(rel) / ds
    dw = np.maximum(np.concatenate([w_int[:1], w_int]), np.concatenate([w_int, w_int[-1:]]))
    with np.errstate(divide="ignore", invalid="ignore"):
        caps = [
            np.min(np.where(np.abs(dq) > TINY, c.v_max / np.abs(dq), np.inf), axis=1),
            np.min(
                np.where(
                    np.abs(d2q) > TINY,
                    np.sqrt(ACCELERATION_SHARE * c.a_max / np.abs(d2q)),
                    np.inf,
                ),
                axis=1,
            ),
            np.where(dp > TINY, c.tool_speed[:, 0] / dp, np.inf),
            np.where(dw > TINY, c.tool_speed[:, 1] / dw, np.inf),
        ]
        acc = [
            np.min(
                np.where(
                    np.abs(dq) > TINY, (1 - ACCELERATION_SHARE) * c.a_max / np.abs(dq), np.inf
                ),
                axis=1,
            ),
            np.where(dp > TINY, c.tool_acceleration[:, 0] / dp, np.inf),
            np.where(dw > TINY, c.tool_acceleration[:, 1] / dw, np.inf),
        ]
    cap = CAP_MARGIN * np.minimum.reduce(caps)
    acc_s = CAP_MARGIN * np.minimum.reduce(acc)
    acc_int = np.minimum(acc_s[:-1], acc_s[1:])
    acc_int = np.where(np.isfinite(acc_int), acc_int, 1e6)
    if c.jerk is not None:
        return s_curve_chunk(c, s, path, cap, acc_int, dp, dw)
    timing = GridTiming(s, np.minimum(cap, 1e9), acc_int)
    t = timing.t
    bc = ([(1, 0.0), (2, 0.0)], [(1, 0.0), (2, 0.0)])
    law = make_interp_spline(t, s, k=5, bc_type=bc)
    # Dense check of the limits between the knots.
    frac = np.arange(CHECKS_PER_INTERVAL) / CHECKS_PER_INTERVAL
    dense = (t[:-1, None] + np.diff(t)[:, None] * frac).ravel()
    _, vel, accel = evaluate(law, path, dense, float(t[-1]))
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
