"""Where a path leaves the robot's workspace, and a controller's stall there restated as that exit.

The IK-based methods find the exit themselves (``core.cartesian.ik_on_path.on_label``: no solution
at all is ``unreachable``); the resolved-rate controllers solve no IK, so at the outer rim they stall
(``singularity``, ``no_convergence``) or hit their rate limits near or past it. ``controller_exit``
makes every method answer the same there: ``unreachable`` at the s where the path leaves.
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.errors import PlanningError, Unreachable
from core.kinematics import Kinematics
from core.path import Path

RIM_GRID = 41
"""Path parameters probed (evenly, s in [0, 1]) for the first pose with no IK solution at all."""
RIM_BISECTIONS = 14
"""Halvings of the probe interval that brackets it (to 0.025 / 2^14 ~ 1.5e-6 in s)."""
RIM_WINDOW = 0.02
"""A controller failure at most this much of s before the path leaves the workspace is that exit."""


def first_unreachable(
    kin: Kinematics, path: Path, deadline: Deadline = NO_DEADLINE
) -> float | None:
    """The smallest s at which ``path``'s pose has no IK solution at all (``kin.ik_all`` empty and
    none only outside the limits: off the workspace), to ``RIM_BISECTIONS`` halvings of the probe
    grid; None when every probed pose is reachable or the robot has no configuration labels (then
    ``ik_all`` is one seeded solve and cannot tell "off the workspace" from "not found")."""
    if not kin.configuration_labels:
        return None

    def off(s: float) -> bool:
        sols = kin.ik_all(path.pose(s))
        return len(sols.positions) == 0 and not sols.outside_limits

    grid = np.linspace(0.0, 1.0, RIM_GRID)
    for k, s in enumerate(grid):
        deadline.check("locating where the path leaves the workspace")
        if off(float(s)):
            if k == 0:
                return 0.0
            lo, hi = float(grid[k - 1]), float(s)
            for _ in range(RIM_BISECTIONS):
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if off(mid) else (mid, hi)
            return hi
    return None


def controller_exit(
    kin: Kinematics, path: Path, failure: PlanningError, deadline: Deadline = NO_DEADLINE
) -> PlanningError:
    """A controller's failure restated where it is the path leaving the workspace: a resolved-rate
    run does not solve IK, so at the outer rim it stalls (``singularity``, ``no_convergence``) or
    hits its rate limits (``joint_rate_limit``) near or past where the pose became unreachable.
    When the path has a first unreachable s no more than ``RIM_WINDOW`` after the failure's s, the
    answer is ``Unreachable`` at that s, as every other method reports it; else ``failure``."""
    if failure.code not in ("singularity", "joint_rate_limit", "no_convergence"):
        return failure
    s_out = first_unreachable(kin, path, deadline)
    if s_out is None or failure.s is None or s_out > failure.s + RIM_WINDOW:
        return failure
    return Unreachable(
        f"no IK solution at s={s_out:.4f}: the path leaves the robot's workspace there (the "
        f"controller {failure.code.replace('_', ' ')} at s={failure.s:.4f} is that exit)",
        s=s_out,
    )
