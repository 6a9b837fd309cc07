"""``resolved_rate``: pseudo-inverse resolved-rate control along the line (course notes sec. 7.2),
simulated tick by tick (``core.cartesian.rate.control``), the ticks turned into a finished result
(``core.cartesian.rate.output``)."""

from __future__ import annotations

from core.cartesian.rate.control import simulate
from core.cartesian.rate.output import result_of
from core.cartesian.task import CartesianResult, CartesianTask


def plan_resolved_rate(task: CartesianTask) -> CartesianResult:
    """Plan ``task`` by pseudo-inverse resolved-rate control (a finished result)."""
    return result_of(task, simulate(task, "resolved_rate"), "resolved_rate")
