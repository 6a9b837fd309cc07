"""Effort limits on a Cartesian plan: the same motion, slowed until its torque keeps them.

A Cartesian plan whose timing the service chooses (no ``duration``) is held to ``task.effort``
after the method planned it: the returned motion (``core.joint.effort.HermiteMotion``: between
consecutive points the quintic through their positions, velocities and accelerations) is checked
densely and, over a limit, slowed uniformly (``held_trajectory``: times by k, velocities by 1/k,
accelerations by 1/k^2; the path, the deviation and the configurations are unchanged). Gravity
alone over a limit is ``Infeasible`` naming the joint and the path parameter ``s`` there. With
dynamics the result's diagnostics carry ``peak_effort`` (|tau| per joint at the returned points
and between them). Units: [N m or N], [s].
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import InputError, PlanningError
from core.joint.effort import HermiteMotion, held_trajectory, peak_effort, slowed


def _slowed(result: CartesianResult, k: float) -> CartesianResult:
    """``result`` run ``k`` (> 1) times slower (its knots' and dense checks' times too)."""
    knots = result.knots
    if knots is not None:
        knots = {**knots, "times": np.asarray(knots["times"], dtype=float) * k}
    deviation = result.deviation
    if deviation is not None:
        deviation = replace(deviation, times=deviation.times * k)
    return replace(
        result,
        trajectory=slowed(result.trajectory, k),
        knots=knots,
        deviation=deviation,
        warnings=(*result.warnings, f"slowed {k:.4g} times to keep the effort limits"),
    )


def held_effort(task: CartesianTask, result: CartesianResult) -> CartesianResult:
    """``result`` slowed until its torque keeps ``task.effort`` (module docstring), with
    ``peak_effort`` in its diagnostics when the robot has dynamics."""
    if task.effort is not None and task.duration is not None:
        raise InputError(
            "limits.effort applies when the service chooses the timing (give no duration)",
            field=("limits", "effort"),
        )
    if len(result.trajectory.times) < 2:
        return result
    if task.effort is not None:
        dev = result.deviation
        duration = result.trajectory.duration

        def where(share: float) -> float:  # the path parameter at a share of the duration
            return share if dev is None else float(np.interp(share * duration, dev.times, dev.s))

        try:
            k = held_trajectory(
                result.trajectory, task.effort, task.robot.joint_names, task.deadline, where
            )
        except PlanningError as err:
            if err.field is None:
                err.field = ("limits", "effort")
            raise
        if k > 1.0:
            result = _slowed(result, k)
    if task.dynamics is None:
        return result
    tr = result.trajectory
    effort = peak_effort(task.dynamics, HermiteMotion(tr), tr.times, task.gravity)
    return replace(result, diagnostics={**result.diagnostics, "peak_effort": effort})
