"""Why a DLS run with velocity dampers left the line: the obstacle in its way.

With an environment ``resolved_rate_dls`` keeps the clearance by velocity-damper rows in its QP
(``core.clearance.VelocityDampers``). Where the line itself passes through an obstacle, the dampers
push the tool off the line, beyond its tolerance. The other methods answer that request with 422
``collision`` at the s where the tool, following the line, first comes within the clearance (the
service's continuous check); ``blocking_contact`` gives the DLS the same answer rather than a
deviation blamed on the sampling: the same controller run again without the dampers (the tool on
the line), its ticks checked continuously, its first contact restated as the failure.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core.cartesian.rate.control import simulate
from core.cartesian.rate.ticks import RateRun
from core.cartesian.task import CartesianTask
from core.clearance import approach_text
from core.errors import Collision
from core.path import Path


class Detour(NamedTuple):
    """Why the dampers made the tool leave the line: ``failure`` (the contact as ``Collision``),
    ``free`` (the run without dampers, on the line) and ``clear`` (its last tick before the
    contact: ticks ``0..clear`` and the motion between them are clear)."""

    failure: Collision
    free: RateRun
    clear: int


def blocking_contact(
    task: CartesianTask, line: Path, run: RateRun, first_out: int
) -> Detour | None:
    """The contact that made ``run`` (``resolved_rate_dls`` with the dampers of
    ``task.clearance``) leave the tolerance band at tick ``first_out``, or None.

    The controller is run again without the dampers and its ticks checked continuously
    (``Clearance.check_path``, joints linear between ticks). Its first contact is the cause when
    that run is still within the tolerances at every tick up to the contact (else the line was
    lost for another reason first: damping, rate bounds). The ``Collision`` carries the contact's
    ``time_from_start`` (on the free run's clock, which is the nominal one up to there), ``links``
    (robot link, obstacle or link), ``distance`` [m] and ``s``: the line parameter of the tool
    there.

    Args:
        task: The task (``task.clearance`` set).
        line: ``task.line()``.
        run: The run with dampers.
        first_out: First tick of ``run`` outside the tolerance band (``< len(run.s)``).
    """
    clearance = task.clearance
    if clearance is None or first_out >= len(run.s):
        return None
    free = simulate(task, "resolved_rate_dls")
    times = np.arange(len(free.s)) * free.dt
    contact = getattr(clearance.check_path(times, free.positions), "contact", None)
    if contact is None:
        return None
    upto = min(int(contact.index) + 2, len(free.s))  # the ticks around the contact segment
    dev = line.deviation(
        task.robot.fk_many(free.positions[:upto]),
        task.position_tolerance,
        task.orientation_tolerance,
    )
    if (dev.position > task.position_tolerance).any() or (
        dev.orientation > task.orientation_tolerance
    ).any():
        return None
    t = float(contact.time)
    q = np.array(
        [np.interp(t, times, free.positions[:, j]) for j in range(free.positions.shape[1])]
    )
    s = float(np.clip(line.deviation(task.robot.fk(q)[None]).s[0], 0.0, 1.0))
    a, b = contact.links
    failure = Collision(
        f"{approach_text(a, b, float(contact.distance), would=True)} at s={s:.4f} "
        f"(t = {t:.4f} s): the line passes through it, and resolved_rate_dls keeps the clearance "
        f"only by leaving the line beyond the tolerance",
        s=s,
        extra={"time_from_start": t, "links": [a, b], "distance": float(contact.distance)},
    )
    return Detour(failure, free, int(contact.index))
