"""The ``trapezoidal`` law on a joint path: the phase-plane trapezoid, smoothed to C4, within limits.

A motion program's chunk (a rest-to-rest stretch of its joint path) is timed by:

1. the shortest s(t) under the caps of ``core.timing.path_limits`` (``GridTiming``, the forward /
   backward pass on the phase plane: s'' piecewise constant, a trapezoid where nothing binds);
2. a quintic spline through its timed grid (``SplineLaw``: s, s', s'' continuous, zero s' and s''
   at both ends), so q(t) = q(s(t)) is as smooth as the path (C4 for the program's spline): no
   acceleration or jerk step between two returned points;
3. a dense check (``CHECKS_PER_INTERVAL`` per grid interval) of joint velocity and acceleration
   against their limits; over them, time is stretched uniformly by the smallest factor that holds
   (velocities scale by 1/k, accelerations by 1/k^2): ``Stretched``.

The result is the program's "common timing" of round 2, unchanged but for the smoother path.
"""

from __future__ import annotations

import numpy as np

from core.errors import Infeasible
from core.timing.joint_path import JointPath
from core.timing.path_limits import PathLimits, path_caps
from core.timing.path_profile import SplineLaw, Stretched, dense_times, joint_motion, stretch_for
from core.timing.speed_limited import GridTiming
from core.trajectory import MAX_DURATION

CHECKS_PER_INTERVAL = 10
"""Dense checks of the limits per grid interval."""
MAX_CAP = 1e9
"""[1/s] caps above this (a path that barely moves) count as this."""


def smooth_trapezoid(path: JointPath, limits: PathLimits) -> Stretched:
    """The timed law of ``path`` under ``limits`` (see the module docstring); s from 0 to
    ``path.length``."""
    s = limits.s
    caps = path_caps(path, limits)
    # GridTiming runs over u = s / length in [0, 1]: u' = s' / length, u'' = s'' / length
    length = float(path.length)
    grid = GridTiming(
        s / length, np.minimum(caps.cap / length, MAX_CAP), caps.acceleration / length
    )
    if not grid.duration <= MAX_DURATION:
        raise Infeasible(
            f"the stretch would last {grid.duration:.4g} s under these limits, over the "
            f"{MAX_DURATION:g} s bound of any trajectory"
        )
    law = SplineLaw(grid.t, s)
    dense = dense_times(grid.t, CHECKS_PER_INTERVAL)
    _, vel, acc = joint_motion(path, law, dense)
    v_lim = np.repeat(np.minimum(limits.velocity[:-1], limits.velocity[1:]), CHECKS_PER_INTERVAL, 0)
    a_lim = np.repeat(
        np.minimum(limits.acceleration[:-1], limits.acceleration[1:]), CHECKS_PER_INTERVAL, 0
    )
    ratio_v = float(np.max(np.abs(vel[:-1]) / v_lim))
    ratio_a = float(np.max(np.abs(acc[:-1]) / a_lim))
    return Stretched(law, stretch_for((ratio_v, ratio_a)))
