"""The collision stage of a Cartesian plan: check the answer, then stop before a contact.

``collide`` runs ``core.collisions`` on a planned, finished ``CartesianResult``: the goal
configuration (a full plan's last point), then the whole motion continuously. A contact is located
on the path by the path's own closest point (``Path.deviation`` of the tool pose there: exact on
lines and arcs alike) and is 422 ``collision``; with ``allow_partial`` the plan stops before it:
the path up to the last clear returned point is planned again by the same method, to rest, and
checked (``STOP_TRIES`` prefixes, each ``STOP_SHRINK`` of the last); when none is clear, the
answer is the returned points before the contact, ending in motion (``MOVING_END``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from core.cartesian.check import finish
from core.cartesian.partial import MIN_FRACTION, partial_warning
from core.cartesian.task import CartesianResult, CartesianTask
from core.collisions import (
    MOVING_END,
    STOP_SHRINK,
    STOP_TRIES,
    ContactFound,
    End,
    check_ends,
    check_motion,
    collision_error,
    cut_before,
)
from core.errors import Collision, PlanningError
from core.kinematics import Clearance

Planned = Callable[[CartesianTask], CartesianResult]
"""A task -> its finished, enforced result (the method's plan before the collision stage)."""


def path_parameter(task: CartesianTask, q: np.ndarray) -> float:
    """The path parameter s in [0, 1] of configuration ``q`` ``(dof,)``: the path's closest point to
    the tool pose there (``Path.deviation``), for every path shape."""
    pose = task.robot.fk(np.asarray(q, dtype=float))[None]
    line = task.line()
    return float(line.deviation(pose, task.position_tolerance, task.orientation_tolerance).s[0])


def check_start(task: CartesianTask) -> None:
    """Before planning: the start (and a goal given as joints) must be clear (``Collision``)."""
    check_ends(
        task.collision_check,
        (End("start", task.q_start, 0.0, 0.0), End("goal", task.q_goal, None, 1.0)),
    )


def collide(task: CartesianTask, result: CartesianResult, planned: Planned) -> CartesianResult:
    """``result`` checked for collisions (see the module docstring); ``planned`` re-plans a prefix."""
    clearance = task.collision_check
    if clearance is None:
        return result
    traj = result.trajectory
    if result.fraction >= 1.0:
        goal = End("goal", traj.positions[-1], float(traj.times[-1]), 1.0)
        check_ends(clearance, (goal,))
    found = check_motion(traj, clearance)
    if found.contact is None:
        return replace(result, clearance=found.report)
    failure = collision_error(found.contact, s=path_parameter(task, found.contact.q))
    if not task.allow_partial:
        raise failure
    return stop_before(task, result, found.contact, failure, planned, clearance)


def stop_before(
    task: CartesianTask,
    result: CartesianResult,
    contact: ContactFound,
    failure: Collision,
    planned: Planned,
    clearance: Clearance,
) -> CartesianResult:
    """The plan up to just before ``contact`` (see the module docstring)."""
    traj = result.trajectory
    last = traj.positions[contact.index]
    end = min(float(result.fraction), path_parameter(task, last))
    shrink = end
    for _ in range(STOP_TRIES):
        if shrink < MIN_FRACTION:
            break
        short = replace(task.prefix(shrink), q_goal=None, allow_partial=False)
        try:
            prefix = planned(short)
        except PlanningError:
            shrink *= STOP_SHRINK
            continue
        found = check_motion(prefix.trajectory, clearance)
        if found.contact is not None:
            shrink *= STOP_SHRINK
            continue
        knots = prefix.knots
        if knots is not None:
            knots = {**knots, "s": knots["s"] * shrink}
        return replace(
            prefix,
            fraction=shrink,
            failure=failure,
            knots=knots,
            warnings=(partial_warning(shrink, failure), *prefix.warnings),
            clearance=found.report,
        )
    # no shorter path planned clear: the returned points before the contact, measured anew
    cut = finish(task, replace(result, trajectory=cut_before(traj, contact)))
    return replace(
        cut,
        fraction=end,
        failure=failure,
        warnings=(partial_warning(end, failure), *cut.warnings, MOVING_END),
        clearance=check_motion(cut.trajectory, clearance).report,
    )
