"""Plan a Cartesian task: validate -> ``METHODS[method]`` -> check -> finish -> enforce.

``plan`` is the one entry point the service calls. Every method validates its own entry (it may be
called directly), returns a ``CartesianResult`` and, when it did not ``finish`` it (limits, dense
deviation, singular values), ``plan`` finishes it here, so no trajectory leaves core unchecked.
"""

from __future__ import annotations

from core.cartesian.check import enforce, finish
from core.cartesian.methods import METHODS
from core.cartesian.partial import PARTIAL_ERRORS, SHORTER_ERRORS, plan_partial
from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import InputError


def plan(task: CartesianTask, method: str) -> CartesianResult:
    """Plan ``task`` with ``method`` (a name in ``METHODS``); ``InputError`` for any other name."""
    planner = METHODS.get(method)
    if planner is None:
        raise InputError(
            f"method must be one of {', '.join(METHODS)}",
            field=("method",),
            extra={"methods": list(METHODS)},
        )

    def checked(t: CartesianTask) -> CartesianResult:
        result = planner(t)
        if result.deviation is None:
            result = finish(t, result)
        return enforce(t, result)

    result = planner(task)
    if result.deviation is None:
        result = finish(task, result)
    try:
        return enforce(task, result)
    except SHORTER_ERRORS:
        # A partial plan (allow_partial) whose prefix breaks the limits before its failure (a rate
        # controller's ticks accelerate hard near a singularity): re-plan a shorter prefix.
        failure = result.failure
        located = isinstance(failure, PARTIAL_ERRORS) and failure.s is not None
        if not (task.allow_partial and located and failure.field is None):
            raise
        return plan_partial(task, checked, failure)
