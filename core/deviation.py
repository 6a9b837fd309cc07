"""Deviation of a returned joint trajectory from the Cartesian straight line, measured densely.

The promise of every Cartesian method is about what is returned, not about the samples a planner
looked at. Between two consecutive returned points a controller interpolates: the ROS 2 joint
trajectory controller uses a cubic Hermite spline through positions and velocities, and a simple
client interpolates joints linearly. ``measure_deviation`` checks both at ``checks`` interior points
of every interval (so at least 10 checks between consecutive points by default) and reports the
worse of the two, position [m] and orientation [rad] separately, against the line's closest point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from core.kinematics import Kinematics
from core.line import StraightLine
from core.trajectory import Trajectory

DEFAULT_CHECKS = 10
"""Interior check points between two consecutive returned points."""


@dataclass(frozen=True)
class DeviationReport:
    """Dense deviation of a trajectory from its line.

    Attributes:
        max_position: Largest position deviation [m] anywhere checked.
        max_orientation: Largest orientation deviation [rad] anywhere checked.
        segment_position: Largest position deviation [m] within each interval, shape ``(N-1,)``.
        segment_orientation: Largest orientation deviation [rad] within each interval, ``(N-1,)``.
        times: Check times [s], shape ``(M,)`` with ``M = (N-1)(checks+1)+1``.
        s: Closest path parameter at each check, ``(M,)``.
        position: Position deviation [m] at each check, ``(M,)``.
        orientation: Orientation deviation [rad] at each check, ``(M,)``.
    """

    max_position: float
    max_orientation: float
    segment_position: np.ndarray
    segment_orientation: np.ndarray
    times: np.ndarray
    s: np.ndarray
    position: np.ndarray
    orientation: np.ndarray


def dense_times(times: np.ndarray, checks: int = DEFAULT_CHECKS) -> np.ndarray:
    """``times`` (N,) with ``checks`` evenly spaced points inserted in every interval: (M,)."""
    times = np.asarray(times, dtype=float)
    frac = np.arange(checks + 1) / (checks + 1)
    inner = times[:-1, None] + frac[None, :] * np.diff(times)[:, None]
    return np.append(inner.ravel(), times[-1])


def interpolate_linear(times: np.ndarray, positions: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Joint positions at ``t`` (M,) by linear interpolation of ``positions`` (N, dof): (M, dof)."""
    idx = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = times[idx + 1] - times[idx]
    a = ((t - times[idx]) / h)[:, None]
    return (1.0 - a) * positions[idx] + a * positions[idx + 1]


def measure_deviation(
    kin: Kinematics,
    line: StraightLine,
    traj: Trajectory,
    checks: int = DEFAULT_CHECKS,
    position_tolerance: float = 1e-3,
    orientation_tolerance: float = 1e-2,
) -> DeviationReport:
    """Measure how far the tool strays from ``line`` along ``traj`` (see the module docstring).

    Args:
        kin: The robot.
        line: The straight line the tool should follow.
        traj: The returned trajectory (at least 2 points).
        checks: Interior checks per interval, >= 1.
        position_tolerance: [m], only weighs position against orientation (see ``StraightLine``).
        orientation_tolerance: [rad], likewise.
    """
    t = dense_times(traj.times, checks)
    q_lin = interpolate_linear(traj.times, traj.positions, t)
    q_herm = CubicHermiteSpline(traj.times, traj.positions, traj.velocities, axis=0)(t)
    devs = [
        line.deviation(kin.fk_many(q), position_tolerance, orientation_tolerance)
        for q in (q_lin, q_herm)
    ]
    worst = 0 if np.max(devs[0].position) >= np.max(devs[1].position) else 1
    position = np.maximum(devs[0].position, devs[1].position)
    orientation = np.maximum(devs[0].orientation, devs[1].orientation)
    n = len(traj.times)
    per = checks + 1
    seg_pos = _segment_max(position, n, per)
    seg_ori = _segment_max(orientation, n, per)
    return DeviationReport(
        max_position=float(position.max()),
        max_orientation=float(orientation.max()),
        segment_position=seg_pos,
        segment_orientation=seg_ori,
        times=t,
        s=devs[worst].s,
        position=position,
        orientation=orientation,
    )


def _segment_max(values: np.ndarray, n: int, per: int) -> np.ndarray:
    """Max over each interval's checks, both end points included: (n-1,)."""
    body = values[:-1].reshape(n - 1, per).max(axis=1)
    return np.maximum(body, values[per::per])
