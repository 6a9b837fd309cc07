"""``resolved_rate_dls``: damped least squares as a QP (``core.cartesian.rate.qp``: build once,
update and warm-start each tick), simulated tick by tick (``core.cartesian.rate.control``). With an
environment (``task.clearance``) each tick's QP gets velocity-damper rows (``core.clearance``)."""

from __future__ import annotations

from core.cartesian.rate.control import simulate
from core.cartesian.rate.output import result_of
from core.cartesian.task import CartesianResult, CartesianTask
from core.clearance import VelocityDampers
from core.errors import InputError


def plan_resolved_rate_dls(task: CartesianTask) -> CartesianResult:
    """Plan ``task`` by damped-least-squares resolved-rate control (a finished result)."""
    dampers = None
    if task.clearance is not None:
        if task.solver != "osqp":
            raise InputError(
                "with an environment resolved_rate_dls keeps the clearance with rows in its QP, "
                "which needs solver 'osqp'",
                field=("solver",),
            )
        dampers = VelocityDampers(task.clearance, task.control_period)
    return result_of(task, simulate(task, "resolved_rate_dls", dampers), "resolved_rate_dls")
