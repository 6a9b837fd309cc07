"""Partial plans (``allow_partial``): a located failure becomes the plan of the reachable prefix.

One set of rules for every method: which failures a prefix can stop before (``PARTIAL_ERRORS``: a
failure located at ``s``), how many times a prefix is retried (``PARTIAL_TRIES``), and what the
result says (``partial_warning`` first among the warnings, ``fraction`` < 1, ``failure`` set). How
the prefix is found is the method's: the knot methods re-plan the line cut short
(``plan_partial``), ``sampled`` cuts its walk, the rate controllers keep the ticks before the failure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from core.cartesian.task import CartesianResult, CartesianTask
from core.errors import (
    BranchFlip,
    Infeasible,
    JointLimit,
    JointRateLimit,
    PlanningError,
    Singularity,
    Unreachable,
)

PARTIAL_ERRORS = (Unreachable, JointLimit, BranchFlip, Singularity)
"""Failures at a path parameter ``s`` that a partial plan stops before."""
SHORTER_ERRORS = (Infeasible, JointRateLimit)
"""Failures of the 200 rule (``check.enforce``) that a shorter prefix may avoid."""
SHORTEN = 0.7
"""Share of a prefix kept when it fails the 200 rule."""
SHORTEN_TRIES = 5
"""Extra prefixes tried when they fail the 200 rule (the shortest: SHORTEN**5, 17 %)."""
MIN_FRACTION = 1e-3
"""Shortest prefix [share of s] a re-planned partial plan may return."""
PARTIAL_TRIES = 3
"""Prefixes tried before the first failure is raised after all."""


def partial_warning(fraction: float, failure: PlanningError) -> str:
    """The first warning of a partial plan: how much of the line it covers and why it stops."""
    return f"planned {fraction:.1%} of the line: {failure.detail}"


def plan_partial(
    task: CartesianTask,
    plan: Callable[[CartesianTask], CartesianResult],
    failure: PlanningError | None = None,
) -> CartesianResult:
    """``plan(task)``; with ``task.allow_partial``, a failure at ``s`` (unreachable, joint limit,
    branch flip, singularity) gives ``plan`` of the prefix of the line up to where it was last
    reached (``failure.s_reached``, else just before ``s``): ``fraction`` < 1, ``failure`` set, the
    knots' ``s`` on the whole line.

    ``failure``: that failure already met (``plan(task)`` is not tried again). A prefix that fails
    the 200 rule (``SHORTER_ERRORS``: its accelerations or deviation, as a rate controller's
    ticks up to a singularity do) is retried ``SHORTEN`` times shorter (``PARTIAL_TRIES +
    SHORTEN_TRIES`` prefixes in all)."""
    if failure is None:
        try:
            return plan(task)
        except PARTIAL_ERRORS as err:
            if not task.allow_partial or err.s is None or err.field is not None:
                raise
            failure = err
    if failure.s is None:
        raise failure
    fail_at, reached = float(failure.s), failure.s_reached
    for _ in range(PARTIAL_TRIES + SHORTEN_TRIES):
        end = float(reached) if reached is not None else 0.95 * fail_at
        if end < MIN_FRACTION:
            raise failure
        prefix = replace(task.prefix(end), q_goal=None, allow_partial=False)
        try:
            result = plan(prefix)
            break
        except PARTIAL_ERRORS as err:
            if err.s is None:
                raise
            # The prefix's own s runs over [0, 1]: on the whole line it is end * s.
            fail_at = end * float(err.s)
            reached = None if err.s_reached is None else end * float(err.s_reached)
        except SHORTER_ERRORS:
            fail_at, reached = end * SHORTEN / 0.95, None
    else:
        raise failure
    knots = None if result.knots is None else {**result.knots, "s": result.knots["s"] * end}
    return replace(
        result,
        fraction=end,
        failure=failure,
        warnings=(partial_warning(end, failure), *result.warnings),
        knots=knots,
    )
