"""Plan a Cartesian task: the one pipeline of every method.

    check_start -> METHODS[method] -> finish -> enforce (-> shorter prefix) -> effort -> collide
    -> result

``plan`` is the one entry point the service calls (``/v1/trajectories/cartesian``, every row of
``/v1/compare``, every LIN/CIRC segment of a program). The start (and a goal given as joints) is
checked for collisions before any method runs; every method validates its own entry (it may be
called directly) and returns a ``CartesianResult``; ``plan`` finishes it when the method did not
(limits, dense deviation, singular values), applies the 200 rule (``check.enforce``), slows it
until its torque keeps the effort limits (``core.cartesian.effort``: with dynamics, ``peak_effort``
in its diagnostics), and hands it to the collision stage (``core.cartesian.stop``: the continuous check, and with ``allow_partial``
the stop before a contact, re-planned by the same method). No trajectory leaves core unchecked.
"""

from __future__ import annotations

from functools import partial

from core.cartesian.check import enforce, finish
from core.cartesian.effort import held_effort
from core.cartesian.methods import METHODS, Planner
from core.cartesian.partial import PARTIAL_ERRORS, SHORTER_ERRORS, plan_partial
from core.cartesian.stop import check_start, collide
from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import InputError


def planner_of(method: str) -> Planner:
    """The ``METHODS`` entry ``method``; ``InputError`` at ``method`` for any other name."""
    planner = METHODS.get(method)
    if planner is None:
        raise InputError(
            f"method must be one of {', '.join(METHODS)}",
            field=("method",),
            extra={"methods": list(METHODS)},
        )
    return planner


def plan(task: CartesianTask, method: str) -> CartesianResult:
    """Plan ``task`` with ``method`` (a name in ``METHODS``): see the module docstring."""
    planner = planner_of(method)
    check_start(task)
    checked = partial(_checked, planner)
    return collide(task, planned(task, planner), checked)


def planned(task: CartesianTask, planner: Planner) -> CartesianResult:
    """The method's plan, finished and held to the 200 rule (no collision stage): a partial plan
    (``allow_partial``) whose prefix breaks the rule before its failure (a rate controller's ticks
    accelerate hard near a singularity) is planned shorter."""
    result = planner(task)
    if result.deviation is None:
        result = finish(task, result)
    try:
        return held_effort(task, enforce(task, result))
    except SHORTER_ERRORS:
        failure = result.failure
        located = isinstance(failure, PARTIAL_ERRORS) and failure.s is not None
        if failure is None or not (task.allow_partial and located and failure.field is None):
            raise
        return plan_partial(task, partial(_checked, planner), failure)


def _checked(planner: Planner, task: CartesianTask) -> CartesianResult:
    """One planning of ``task`` held to the 200 rule (a prefix of a partial plan)."""
    result = planner(task)
    if result.deviation is None:
        result = finish(task, result)
    return held_effort(task, enforce(task, result))
