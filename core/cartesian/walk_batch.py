"""The fast path of the ``sampled`` walk for 6R arms with configuration labels: IK of every pose of
the walk's grid at once on the start's configuration (``Kinematics.ik_many``: one batched analytic
call, verified by FK to 1e-9 m and rad), then every check of the point-by-point walk
(``core.cartesian.walk``) vectorized over the points. The batch is taken only when all of them pass
at every point; anything else (a pose without the start's configuration, a joint limit, a small
singular value, joint rates the speed floor cannot meet, a joint step the grid is too coarse for)
returns None, and the point-by-point walk locates and names the failure as before.
"""

from __future__ import annotations

import numpy as np

from core.cartesian.ik_on_path import follows
from core.cartesian.path_rates import path_rates
from core.cartesian.task import CartesianTask
from core.cartesian.timing import MIN_SPEED_FRACTION, nominal_path_speed
from core.cartesian.walk import MAX_JOINT_STEP, LineWalk, check_grid
from core.kinematics import SINGULAR_VALUE_THRESHOLD
from core.path.base import Path


def batch_walk(task: CartesianTask, line: Path, grid: np.ndarray | None = None) -> LineWalk | None:
    """``walk_line``'s result on ``grid`` (increasing s from 0 to 1, at least as fine as the
    default ``check_grid``, which is the default) when the whole line passes (see the module
    docstring), else None. Only for robots with a label and task space ``pose`` (the batched
    analytic IK); others get None at once."""
    robot = task.robot
    q_start = np.asarray(task.q_start, dtype=float)
    label = robot.configuration(q_start)
    if label is None or robot.task_space != "pose":
        return None
    grid = check_grid(task, line) if grid is None else grid
    path = robot.ik_many(line.poses(grid[1:]), q_start, label)
    if not np.all(path.within_limits):
        return None
    positions = np.vstack([q_start, path.positions])
    rates = path_rates(robot, line, positions, deadline=task.deadline, s=grid)
    if np.any(rates.sigma < SINGULAR_VALUE_THRESHOLD):
        return None
    speed = nominal_path_speed(task, line)
    floor = MIN_SPEED_FRACTION * speed if np.isfinite(speed) else 0.0
    with np.errstate(divide="ignore"):
        cap = np.min(robot.velocity_limits / np.abs(rates.dq_ds), axis=1)
    if np.any(cap < floor):
        return None
    step = rates.dq_ds[:-1] * np.diff(grid)[:, None]
    if np.any(np.abs(step).max(axis=1) > MAX_JOINT_STEP):
        return None
    if not np.all(follows(positions[1:], positions[:-1], step)):
        return None
    return LineWalk(grid, positions, rates, None, len(grid) - 1)
