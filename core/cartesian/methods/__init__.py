"""The Cartesian methods: the ``METHODS`` registry (name -> planner).

A planner is ``(CartesianTask) -> CartesianResult``. Adding a method is one module in this folder
plus one line here; the HTTP schema's ``Literal`` of method names is built from this dict.
"""

from __future__ import annotations

from collections.abc import Callable

from core.cartesian.methods.bounded_deviation import plan_bounded_deviation
from core.cartesian.methods.bounded_deviation_nlp import plan_bounded_deviation_nlp
from core.cartesian.methods.resolved_rate import plan_resolved_rate
from core.cartesian.methods.resolved_rate_dls import plan_resolved_rate_dls
from core.cartesian.methods.sampled import plan_sampled
from core.cartesian.task import CartesianResult, CartesianTask

Planner = Callable[[CartesianTask], CartesianResult]

METHODS: dict[str, Planner] = {
    "sampled": plan_sampled,
    "bounded_deviation": plan_bounded_deviation,
    "bounded_deviation_nlp": plan_bounded_deviation_nlp,
    "resolved_rate": plan_resolved_rate,
    "resolved_rate_dls": plan_resolved_rate_dls,
}
