"""Sampling a collision-free motion into the returned points, certified as returned.

The service's promise is about the returned points with joints moving linearly between them, not
about the path they sample: a chord between two samples of a blend cuts inside it. So:

- the returned times hold every switch time of the timing (``core.timing.switch_times``): a pair
  ``MIN_SPACING`` apart around each grid time where the time-optimal law's s'' jumps (``jumps``:
  its accelerations jump there, at the sharp corners where it stops too), each switch of the
  jerk-limited S-curves (their knots among them), so the returned velocities and accelerations are the exact derivatives of the
  returned motion;
- the returned points are certified as straight segments (``Certifier.path``: the margins of the
  samples bound one another, so only the pairs close to contact are evaluated); when they are not,
  the blends are halved and the motion timed again (``BLEND_HALVINGS`` times), then the corners
  left sharp: the points then lie on the certified segments but for the pair around each stop,
  whose chord passes within picoradians of its corner (certified in turn; failing that, the
  stops themselves are returned points, one point at each switch, every point on a segment).
  The usual continuous check of ``core.collisions`` still runs on every answer.
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.joint.blended_path import BlendedPath
from core.joint.durations import MIN_DURATION
from core.limits import JointLimits
from core.motion.certify import Certifier
from core.motion.timing import Motion, StopAndGo, time_path
from core.timing.path_constraints import PathLimits
from core.timing.switch_times import jumps, with_switches
from core.trajectory import Trajectory

BLEND_HALVINGS = 3
"""Times the blends are halved when the returned points are not certified, before sharp corners."""


def sampled(
    motion: Motion,
    switches: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    joint_names: tuple[str, ...],
    sample_period: float | None,
    samples: int | None,
    max_points: int,
    *,
    pairs: bool,
) -> Trajectory:
    """The returned points of ``motion`` (``switches`` held: ``with_switches``, ``pairs`` where
    the acceleration jumps), exactly ``start`` and ``goal`` at rest at the ends."""
    switches = np.asarray(switches, dtype=float)
    if motion.duration < MIN_DURATION:  # standing still
        switches = np.array([0.0, MIN_DURATION])
    times = with_switches(switches, sample_period, samples, max_points, pairs=pairs)
    q, qd, qdd = motion.sample(np.minimum(times, motion.duration))
    q[0], q[-1] = start, goal
    qd[0] = qd[-1] = 0.0
    return Trajectory(times, q, qd, qdd, joint_names)


def certified_samples(
    certifier: Certifier,
    path: BlendedPath,
    limits: PathLimits,
    joint_names: tuple[str, ...],
    sample_period: float | None,
    samples: int | None,
    max_points: int,
    deadline: Deadline = NO_DEADLINE,
) -> tuple[Trajectory, BlendedPath]:
    """The time-optimal samples of ``path`` under ``limits``, certified as returned (module
    docstring), and the path they sample (its blends possibly reduced)."""
    knots = path.knots
    sampling = (joint_names, sample_period, samples, max_points)
    for halving in range(BLEND_HALVINGS + 2):
        last = halving == BLEND_HALVINGS + 1
        if last:
            path = BlendedPath(knots)  # sharp corners: the points on the certified segments
        motion = time_path(path, limits, joint_names=joint_names, deadline=deadline)
        switches = jumps(motion)
        traj = sampled(motion, switches, knots[0], knots[-1], *sampling, pairs=True)
        if certifier.path(traj.positions).ok:
            return traj, path
        if last:  # one point at each switch, the stops among them: every point on a segment
            return sampled(motion, switches, knots[0], knots[-1], *sampling, pairs=False), path
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
    sampling = (joint_names, sample_period, samples, max_points)
    return sampled(motion, motion.switch_times, knots[0], knots[-1], *sampling, pairs=False)
