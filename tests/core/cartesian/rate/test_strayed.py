"""A controller whose own ticks leave the tolerance band answers infeasible naming the controller
(damping near a singularity), not the sampling: more samples cannot bring ticks back to the line."""

from __future__ import annotations

import numpy as np
import pytest

from core.cartesian.plan import plan
from core.cartesian.rate.control import simulate
from core.cartesian.task import CartesianTask
from core.errors import Infeasible
from tests.core.conftest import xy
from tests.toy_kinematics import ToyPlanar2R


def test_dls_leaving_the_line_at_a_singular_start_names_the_damping() -> None:
    """The 2R toy stretched out (q = 0, singular) to (1.2, 0.3) in 1 s: the DLS damps and the tool
    leaves the line by ~1 cm at the ticks. The answer was 'strays between its returned points ...
    give more samples'; now it names the damping, and its deviation is the ticks' own (the
    largest distance of a tick's tool point from the segment, closed form)."""
    robot = ToyPlanar2R()
    q0 = np.array([0.0, 0.0])
    task = CartesianTask(robot, q0, xy(1.2, 0.3), duration=1.0)
    with pytest.raises(Infeasible) as err:
        plan(task, "resolved_rate_dls")
    detail = err.value.detail
    assert "give more samples" not in detail and "singularity" in detail
    run = simulate(task, "resolved_rate_dls")
    a, b = robot.fk(q0)[:2, 3], np.array([1.2, 0.3])
    d = b - a
    p = robot.fk_many(run.positions)[:, :2, 3]
    t = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
    off = np.linalg.norm(p - (a + t[:, None] * d), axis=1)
    assert err.value.extra["max_position_deviation"] == pytest.approx(off.max(), rel=1e-6)
    assert err.value.s == pytest.approx(t[int(np.argmax(off))], abs=1e-6)
    # with allow_violations the same run is returned, its deviation accepted with a warning
    accepted = plan(CartesianTask(robot, q0, xy(1.2, 0.3), duration=1.0, allow_violations=True),
                    "resolved_rate_dls")  # fmt: skip
    assert any("accepted a deviation" in w for w in accepted.warnings)
