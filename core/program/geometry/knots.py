"""Bounded-deviation LIN/CIRC segments of a program: few IK knots, a spline between them.

A segment with ``method="bounded_deviation"`` is walked like a sampled one (``core.program.walk``,
one branch, every failure located), then its joint path is rebuilt from as few of the walk's IK
solutions as keep the C2 joint spline through them within ``KNOT_SHARE`` of the segment's tolerance
of the path at every walk sample and midpoint between them: knots are added where the spline
strays most (one per offending interval per round) until it holds. The knots include both ends and
the blend cuts (the tool is exactly on the path there, so blends join IK solutions). The program
then times and samples the segment from that spline, so its returned points are off the path by
at most the tolerance instead of the walk's 1e-6 m.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from core.kinematics import Kinematics
from core.path.base import Path

KNOT_SHARE = 0.8
"""Share of the tolerance the knot spline may use at the checked parameters (the rest is margin for
the timing's resampling between them)."""
MAX_ROUNDS = 60


def knot_spline(
    robot: Kinematics,
    path: Path,
    s: np.ndarray,
    q: np.ndarray,
    keep: list[float],
    position_tolerance: float,
    orientation_tolerance: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Knots of a bounded-deviation segment and the joint spline through them at the walk's samples.

    Args:
        robot: FK of the joint positions.
        path: The segment's line or arc (``deviation`` of poses from it).
        s: The walk's path parameters ``(K,)``, increasing from 0.
        q: IK solutions there ``(K, dof)``, one branch.
        keep: Path parameters that must be knots (the blend cuts), when they are walk samples.
        position_tolerance: [m], > 0.
        orientation_tolerance: [rad], > 0.

    Returns:
        ``knots``: indices into ``s`` of the knots (increasing, both ends included), and the spline's
        joint positions at every ``s`` ``(K, dof)`` (equal to ``q`` at the knots).
    """
    n = len(s)
    if n <= 2:
        return np.arange(n), q.copy()
    chosen = {0, n - 1}
    chosen.update(int(i) for i in np.flatnonzero(np.isin(s, keep)))
    mids = 0.5 * (s[:-1] + s[1:])
    checks = np.concatenate([s, mids])
    owner = np.concatenate([np.arange(n), np.arange(n - 1)])  # the walk sample left of each check
    poses_ref = path.poses(checks)
    for _ in range(MAX_ROUNDS):
        knots = np.array(sorted(chosen))
        spline = CubicSpline(s[knots], q[knots])
        dev = path.deviation(
            robot.fk_many(spline(checks)), position_tolerance, orientation_tolerance
        )
        ratio = np.maximum(
            dev.position / position_tolerance, dev.orientation / orientation_tolerance
        )
        # also against the path point at the check's own s (the deviation's s may slide)
        ratio = np.maximum(ratio, _nominal(robot, spline(checks), poses_ref) / position_tolerance)
        bad = ratio > KNOT_SHARE
        if not bad.any():
            return knots, spline(s)
        interval = np.searchsorted(knots, owner, side="right") - 1
        added = False
        for k in np.unique(interval[bad]):
            inside = bad & (interval == k)
            cands = owner[inside]
            cands = cands[(cands > knots[k]) & (cands < knots[min(k + 1, len(knots) - 1)])]
            if len(cands) == 0:  # the worst check is at a knot's right midpoint: split the gap
                lo, hi = knots[k], knots[min(k + 1, len(knots) - 1)]
                if hi - lo >= 2:
                    chosen.add(int((lo + hi) // 2))
                    added = True
                continue
            worst = cands[np.argmax(ratio[inside][np.isin(owner[inside], cands)])]
            chosen.add(int(worst))
            added = True
        if not added:
            break
    return np.arange(n), q.copy()  # every sample a knot: the walk itself


def _nominal(robot: Kinematics, q: np.ndarray, T_ref: np.ndarray) -> np.ndarray:
    """Distance [m] between FK of ``q`` (N, dof) and the reference poses' positions (N, 4, 4)."""
    p = robot.fk_many(q)[:, :3, 3]
    return np.linalg.norm(p - T_ref[:, :3, 3], axis=1)
