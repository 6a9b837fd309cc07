"""Sampling a collision-free motion into the returned points, certified as returned.

The service's promise is about the returned points with joints moving linearly between them, not
about the path they sample: a chord between two samples of a blend cuts inside it, and one that
spans a sharp corner (where the motion stops) cuts the corner. So:

- every instant where the motion stops at a corner is itself a returned point (``Motion.stops``:
  the sharp corners of a ``BlendedPath``, every knot of ``StopAndGo``), as a program's segment
  ends are; a grid point within ``MIN_LAST_INTERVAL`` of one moves onto it;
- the returned points are certified as straight segments (``Certifier.path``: the margins of the
  samples bound one another, so only the pairs close to contact are evaluated); when they are not,
  the blends are halved and the motion timed again (``BLEND_HALVINGS`` times), then the corners
  left sharp: every chord then lies on a certified segment.
"""

from __future__ import annotations

import numpy as np

from core.errors import TooLarge
from core.joint.durations import MIN_DURATION
from core.limits import JointLimits
from core.motion.certify import Certifier
from core.motion.path import BlendedPath
from core.motion.timing import Motion, StopAndGo, time_path
from core.trajectory import MIN_LAST_INTERVAL, Trajectory, sample_times

BLEND_HALVINGS = 3
"""Times the blends are halved when the returned points are not certified, before sharp corners."""


def with_stops(times: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """``times`` ``(N,)`` with every stop instant ``stops`` [s] inside it as a point (a grid point
    closer than ``MIN_LAST_INTERVAL`` moves onto the stop)."""
    out = np.asarray(times, dtype=float).copy()
    extra = []
    for t in np.asarray(stops, dtype=float):
        if not 0.0 < t < out[-1]:
            continue
        k = int(np.argmin(np.abs(out - t)))
        if abs(out[k] - t) < MIN_LAST_INTERVAL and 0 < k < len(out) - 1:
            out[k] = t
        else:
            extra.append(t)
    return np.unique(np.concatenate([out, extra]))


def sampled(
    motion: Motion,
    start: np.ndarray,
    goal: np.ndarray,
    joint_names: tuple[str, ...],
    sample_period: float | None,
    samples: int | None,
    max_points: int,
) -> Trajectory:
    """The returned points of ``motion`` (its stops among them), exactly ``start`` and ``goal``
    at the ends."""
    duration = max(float(motion.duration), MIN_DURATION)
    times = with_stops(sample_times(duration, sample_period, samples, max_points), motion.stops())
    if len(times) > max_points:
        raise TooLarge(
            f"the motion needs {len(times)} points with its stops, over the limit of {max_points}",
            field=("samples",) if samples is not None else ("sample_period",),
        )
    q, qd, qdd = motion.sample(np.minimum(times, motion.duration))
    q[0], q[-1] = start, goal
    return Trajectory(times, q, qd, qdd, joint_names)


def certified_samples(
    certifier: Certifier,
    path: BlendedPath,
    limits: JointLimits,
    joint_names: tuple[str, ...],
    sample_period: float | None,
    samples: int | None,
    max_points: int,
) -> tuple[Trajectory, BlendedPath]:
    """The time-optimal samples of ``path``, certified as returned (module docstring), and the
    path they sample (its blends possibly reduced)."""
    assert limits.velocity is not None and limits.acceleration is not None
    knots = path.knots
    for halving in range(BLEND_HALVINGS + 2):
        if halving == BLEND_HALVINGS + 1:
            path = BlendedPath(knots)  # sharp corners: every chord on a certified segment
        motion = time_path(path, limits.velocity, limits.acceleration)
        traj = sampled(motion, knots[0], knots[-1], joint_names, sample_period, samples, max_points)
        if halving == BLEND_HALVINGS + 1 or certifier.path(traj.positions).ok:
            return traj, path
        path = BlendedPath(knots, path.deviations / 2)
    raise AssertionError("unreachable")  # the last round returns


def stop_and_go_samples(
    knots: np.ndarray,
    limits: JointLimits,
    joint_names: tuple[str, ...],
    sample_period: float | None,
    samples: int | None,
    max_points: int,
) -> Trajectory:
    """Jerk-limited S-curves along the segments through ``knots``, at rest at each knot (a
    returned point): every chord lies on a certified segment."""
    assert limits.velocity is not None and limits.acceleration is not None
    jerk = limits.jerk if limits.jerk is not None else limits.velocity  # unused when standing
    motion = StopAndGo(knots, limits.velocity, limits.acceleration, jerk)
    return sampled(motion, knots[0], knots[-1], joint_names, sample_period, samples, max_points)
