"""Velocity dampers as the DLS QP's extra rows (``core.clearance.VelocityDampers``): rows against
the checker's own damper inputs and the closed-form distances, and the first-order guarantee that a
rate on a row's boundary closes exactly ``gain`` of the margin in one period."""

from __future__ import annotations

import numpy as np
import pytest

from core.clearance import VelocityDampers
from robots import registry
from robots.collision import CollisionChecker, Obstacle, robot_setup

PANDA = registry.get("panda")


def panda_with_ball(offset: float, clearance: float = 0.01) -> tuple[CollisionChecker, np.ndarray]:
    q = PANDA.home + np.random.default_rng(3).normal(scale=0.1, size=7)
    T = np.eye(4)
    T[:3, 3] = PANDA.frame_pose(q, "panda_link4")[:3, 3] + np.array([0.0, offset, 0.0])
    geometry, allowed = robot_setup(PANDA)
    ball = Obstacle("ball", "sphere", radius=0.05, T_base_obstacle=T)
    check = CollisionChecker(
        PANDA, geometry, [ball], clearance=clearance, self_collision=False, allowed_self=allowed
    )
    return check, q


def test_far_obstacle_gives_no_rows() -> None:
    check, q = panda_with_ball(1.0)
    dampers = VelocityDampers(check, 1e-3)
    assert dampers(q) == [] and dampers.evaluations == 1
    # a small step: the motion bound shows every pair still far, no distance query
    assert dampers(q + 1e-3) == [] and dampers.evaluations == 1
    # a step the bound cannot clear: queried again
    assert dampers(q + 0.5) == [] and dampers.evaluations == 2


def test_rows_close_the_gain_share_of_the_margin() -> None:
    check, q = panda_with_ball(0.2)
    dt, gain = 1e-3, 0.05
    dampers = VelocityDampers(check, dt, gain=gain, influence=0.11, capacity=2, buffer=0.0)
    rows = dampers(q)
    margin = check.distances(q[None])[0] - check.threshold
    near = np.sort(margin[margin < 0.11])
    assert len(near) == 3 and len(rows) == 2  # the closest two
    # bounds, closest first: -gain (d - d_safe) / dt
    b = np.array([r[1] for r in rows])
    np.testing.assert_allclose(b, -gain * near[: len(rows)] / dt, atol=1e-6 / dt)
    # a rate on the first row's boundary changes that pair's distance by -gain * margin per period
    a0, b0 = rows[0]
    qd = a0 * b0 / (a0 @ a0)
    h = 1e-7
    rate = (check.distances((q + h * qd)[None])[0] - check.distances(q[None])[0]) / h
    p = int(np.argmin(margin))
    assert rate[p] * dt == pytest.approx(-gain * margin[p], rel=1e-3)


def test_bad_parameters_raise() -> None:
    check, _ = panda_with_ball(1.0)
    with pytest.raises(ValueError):
        VelocityDampers(check, 0.0)
    with pytest.raises(ValueError):
        VelocityDampers(check, 1e-3, gain=1.5)
    with pytest.raises(ValueError):
        VelocityDampers(check, 1e-3, influence=0.01, buffer=0.02)


def test_a_pair_inside_its_threshold_may_only_not_approach() -> None:
    check, q = panda_with_ball(0.15)
    margin = check.distances(q[None])[0] - check.threshold
    assert margin.min() < 0
    rows = VelocityDampers(check, 1e-3)(q)
    assert rows[0][1] == 0.0 and all(b < 0 for _, b in rows[1:])


def test_buffer_moves_the_safe_distance() -> None:
    check, q = panda_with_ball(0.2)
    margin = np.sort(check.distances(q[None])[0] - check.threshold)
    dt, gain, buffer = 1e-3, 0.05, 0.004
    (row,) = VelocityDampers(check, dt, gain=gain, influence=0.1, capacity=1, buffer=buffer)(q)
    assert row[1] == pytest.approx(-gain * (margin[0] - buffer) / dt, rel=1e-6)
