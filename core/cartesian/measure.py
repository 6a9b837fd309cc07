"""Dense measurement of a returned joint trajectory against its line: deviation, singular values.

The promise of every Cartesian method is about what is returned, not about the samples a planner
looked at. Between two consecutive returned points a controller interpolates: the ROS 2 joint
trajectory controller uses a cubic Hermite spline through positions and velocities, and a simple
client interpolates joints linearly. ``measure_deviation`` checks both at ``checks`` interior points
of every interval (so at least 10 checks between consecutive points by default) and reports the
worse of the two, position [m] and orientation [rad] separately, against the line's closest point.
``measure`` does it ``MEASURE_CHUNK`` points at a time under the task's deadline; ``interval_excess``
is the same check per interval as a ratio to the tolerances (what the knot methods split on).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.path_rates import smallest_singular_values
from core.kinematics import Kinematics, jacobians, task_rows
from core.path.base import Path, PathDeviation
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
    line: Path,
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
    # both interpolations in one FK and one deviation call (half the per-call overhead)
    both = line.deviation(
        kin.fk_many(np.concatenate([q_lin, q_herm])), position_tolerance, orientation_tolerance
    )
    m = len(t)
    lin_pos, herm_pos = both.position[:m], both.position[m:]
    worst_s = both.s[:m] if lin_pos.max() >= herm_pos.max() else both.s[m:]
    position = np.maximum(lin_pos, herm_pos)
    orientation = np.maximum(both.orientation[:m], both.orientation[m:])
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
        s=worst_s,
        position=position,
        orientation=orientation,
    )


def _segment_max(values: np.ndarray, n: int, per: int) -> np.ndarray:
    """Max over each interval's checks, both end points included: (n-1,)."""
    body = values[:-1].reshape(n - 1, per).max(axis=1)
    return np.maximum(body, values[per::per])


MEASURE_CHUNK = 2048
"""Returned points measured between two deadline checks (about 0.25 s of work on a 2-core box)."""


def strict_deviation(
    kin: Kinematics, line: Path, q: np.ndarray, tol_p: float, tol_o: float
) -> PathDeviation:
    """Deviation of configurations ``q`` (N, dof) from the line (``StraightLine.deviation``, whose
    orientation term already takes the larger of the two closest-point readings a client may use)."""
    return line.deviation(kin.fk_many(q), tol_p, tol_o)


def min_singular_values(
    robot: Kinematics, positions: np.ndarray, deadline: Deadline = NO_DEADLINE
) -> np.ndarray:
    """Smallest singular value of the task rows of the Jacobian at each row of ``positions``
    (``deadline`` checked every ``MEASURE_CHUNK`` rows)."""
    rows = task_rows(robot.task_space)
    out = []
    for i in range(0, len(positions), MEASURE_CHUNK):
        deadline.check("singular values along the trajectory")
        J = jacobians(robot, positions[i : i + MEASURE_CHUNK])[:, rows]
        out.append(smallest_singular_values(J))
    return np.concatenate(out)


def measure_chunked(
    robot: Kinematics,
    line: Path,
    traj: Trajectory,
    position_tolerance: float,
    orientation_tolerance: float,
    deadline: Deadline = NO_DEADLINE,
) -> DeviationReport:
    """``measure_deviation`` of ``traj`` against ``line``, ``MEASURE_CHUNK`` points at a time
    with ``deadline`` checked between chunks, so a 100,000-point plan (2.2 million checks)
    honors the wall-time budget. Every check depends only on its own interval, so the chunks put
    together give the report of one call (to rounding, 1e-16 m at a chunk's last interval)."""
    n = len(traj.times)
    parts = []
    for i in range(0, n - 1, MEASURE_CHUNK):
        deadline.check("dense deviation measurement")
        j = min(i + MEASURE_CHUNK, n - 1) + 1
        piece = Trajectory(
            traj.times[i:j],
            traj.positions[i:j],
            traj.velocities[i:j],
            traj.accelerations[i:j],
            traj.joint_names,
        )
        parts.append(
            measure_deviation(
                robot,
                line,
                piece,
                position_tolerance=position_tolerance,
                orientation_tolerance=orientation_tolerance,
            )
        )
    if len(parts) == 1:
        return parts[0]

    def joined(name: str) -> np.ndarray:  # each part's last check is the next part's first
        arrays = [getattr(p, name) for p in parts]
        return np.concatenate([a[:-1] for a in arrays[:-1]] + [arrays[-1]])

    return DeviationReport(
        max_position=max(p.max_position for p in parts),
        max_orientation=max(p.max_orientation for p in parts),
        segment_position=np.concatenate([p.segment_position for p in parts]),
        segment_orientation=np.concatenate([p.segment_orientation for p in parts]),
        times=joined("times"),
        s=joined("s"),
        position=joined("position"),
        orientation=joined("orientation"),
    )


def interval_excess(
    kin: Kinematics,
    line: Path,
    traj: Trajectory,
    tol_p: float,
    tol_o: float,
    deadline: Deadline = NO_DEADLINE,
) -> np.ndarray:
    """Largest deviation over the tolerance (1.0: at the bound) in each interval of ``traj``,
    ``(N-1,)``: as ``measure_deviation`` (joints interpolated linearly and by cubic Hermite at
    ``DEFAULT_CHECKS`` points in each interval), with ``strict_deviation``, ``MEASURE_CHUNK``
    intervals at a time with ``deadline`` checked between them."""
    n, per = len(traj.times), DEFAULT_CHECKS + 1
    out = []
    for i in range(0, n - 1, MEASURE_CHUNK):
        deadline.check("bounded deviation: dense measurement")
        j = min(i + MEASURE_CHUNK, n - 1) + 1
        times, positions = traj.times[i:j], traj.positions[i:j]
        t = dense_times(times, DEFAULT_CHECKS)
        q = np.concatenate(
            [
                interpolate_linear(times, positions, t),
                CubicHermiteSpline(times, positions, traj.velocities[i:j], axis=0)(t),
            ]
        )
        dev = strict_deviation(kin, line, q, tol_p, tol_o)
        both = np.maximum(dev.position / tol_p, dev.orientation / tol_o)
        excess = np.maximum(both[: len(t)], both[len(t) :])
        out.append(_segment_max(excess, j - i, per))
    return np.concatenate(out)
