"""The path clock of a rate controller slowed for the joints' acceleration limits.

The controllers track the nominal s(t) of the tool's own limits and bound joint rates, never
accelerations: the PUMA 560's 7 cm line from home at the default 0.25 m/s and 1 m/s^2 asked joint 3
for 1.8 times its 2 rad/s^2 (the time scaling of ``resolved_rate_dls`` holds velocity limits
only). Where the request leaves room (no ``duration``) ``joint_timing`` re-times the line the way
``sampled`` does (``core.cartesian.timing.time_path``: joint velocity and acceleration caps on s'
and s'') along the joint path the first run took, and the controller runs again on that clock.
"""

from __future__ import annotations

import numpy as np

from core.cartesian.task import CartesianTask
from core.cartesian.timing import PathTiming, time_path
from core.errors import PlanningError
from core.path import Path

ACCELERATION_TRIGGER = 0.95
"""Re-time when the run's joint accelerations reach this share of their limits (measured over
``WINDOW`` seconds, the scale of the returned points, so tick-to-tick feedback noise does not count)."""
WINDOW = 0.01
"""[s] Span of the finite differences of the rates that measure the run's accelerations."""
GRID = 201
"""Points of the joint path q(s) (evenly in s) the new timing is computed on."""


def peak_acceleration_ratio(rates: np.ndarray, dt: float, limits: np.ndarray) -> float:
    """Largest ``|qd(t + w) - qd(t)| / (w a_max)`` over the ticks' rates ``(n, dof)`` [rad/s],
    ``w`` the whole ticks nearest ``WINDOW`` (at least one), ``dt`` [s] the tick."""
    w = max(1, round(WINDOW / dt))
    if len(rates) <= w:
        w = max(1, len(rates) - 1)
    if len(rates) < 2:
        return 0.0
    diff = np.abs(rates[w:] - rates[:-w]) / (w * dt)
    return float((diff / np.asarray(limits, dtype=float)).max())


def joint_timing(
    task: CartesianTask, line: Path, s: np.ndarray, positions: np.ndarray
) -> PathTiming | None:
    """s(t) (and the warnings that say where it slows) under the tool limits and the joints' velocity and acceleration limits along the
    joint path ``positions`` ``(n, dof)`` the controller took with setpoint ``s`` ``(n,)``
    (``time_path`` on ``GRID`` points: q(s) interpolated per joint, dq/ds and d2q/ds2 by
    differences), or None where no new timing can be had (a duration is given, the path did not
    reach s = 1, or ``time_path`` fails: a singularity)."""
    if task.duration is not None:
        return None
    s = np.asarray(s, dtype=float)
    keep = np.concatenate([[True], np.diff(s) > 0.0])  # strictly increasing setpoints
    s_run, q_run = s[keep], positions[keep]
    if len(s_run) < 4 or s_run[0] != 0.0 or s_run[-1] < 1.0 - 1e-9:
        return None
    grid = np.linspace(0.0, 1.0, GRID)
    q = np.stack([np.interp(grid, s_run, q_run[:, j]) for j in range(q_run.shape[1])], axis=1)
    dq = np.gradient(q, grid, axis=0)
    d2q = np.gradient(dq, grid, axis=0)
    try:
        return time_path(task, line, grid, dq, d2q)
    except PlanningError:
        return None
