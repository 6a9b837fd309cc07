"""The vectorized Jacobians (``Robot.jacobian_many``, one numpy product over the chain) equal
pinocchio's, one configuration at a time, on every shipped robot and an offset, prismatic inline arm."""

from __future__ import annotations

import numpy as np
import pytest

from core.kinematics import VECTORIZED_JACOBIANS, jacobians
from robots import registry
from tests.robots.inline_urdfs import OFFSET_BASE_URDF


def robots_under_test():
    inline = registry.load_inline(OFFSET_BASE_URDF, "tool", "mount")
    return [registry.get(n) for n in registry.names()] + [inline]


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_jacobian_many_equals_pinocchio(robot) -> None:
    rng = np.random.default_rng(11)
    lo = np.maximum(robot.position_limits[:, 0], -np.pi)
    hi = np.minimum(robot.position_limits[:, 1], np.pi)
    qs = rng.uniform(lo, hi, (200, robot.dof))
    many = robot.jacobian_many(qs)
    assert many.shape == (200, 6, robot.dof)
    one_by_one = np.array([robot.jacobian(q) for q in qs])
    err = np.abs(many - one_by_one).max()
    assert err <= 1e-12, f"{robot.name}: jacobian_many differs from pinocchio by {err:.3g}"


def test_jacobians_helper_agrees_below_and_above_the_threshold() -> None:
    robot = registry.get("panda")
    qs = np.random.default_rng(12).uniform(-1.0, 1.0, (VECTORIZED_JACOBIANS + 3, robot.dof))
    expected = np.array([robot.jacobian(q) for q in qs])
    for n in (1, VECTORIZED_JACOBIANS - 1, VECTORIZED_JACOBIANS + 3):
        assert np.abs(jacobians(robot, qs[:n]) - expected[:n]).max() <= 1e-12


def test_jacobian_many_rejects_a_wrong_shape() -> None:
    from core.errors import InputError

    with pytest.raises(InputError):
        registry.get("ur5").jacobian_many(np.zeros((3, 5)))


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_fk_jacobian_is_fk_and_jacobian(robot) -> None:
    rng = np.random.default_rng(13)
    for q in rng.uniform(-1.0, 1.0, (20, robot.dof)):
        q = np.clip(q, robot.position_limits[:, 0], robot.position_limits[:, 1])
        T, J = robot.fk_jacobian(q)
        assert np.abs(T - robot.fk(q)).max() <= 1e-12
        assert np.abs(J - robot.jacobian(q)).max() <= 1e-12


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_fk_jacobian_loop_reuses_nothing_it_returns(robot) -> None:
    """The loop form (one pinocchio Data for many calls) gives fresh arrays equal to fk/jacobian."""
    loop = robot.fk_jacobian_loop()
    rng = np.random.default_rng(14)
    qs = np.clip(
        rng.uniform(-1.0, 1.0, (20, robot.dof)),
        robot.position_limits[:, 0],
        robot.position_limits[:, 1],
    )
    results = [loop(q) for q in qs]  # kept: a later call must not overwrite an earlier answer
    for q, (T, J) in zip(qs, results, strict=True):
        assert np.abs(T - robot.fk(q)).max() <= 1e-12
        assert np.abs(J - robot.jacobian(q)).max() <= 1e-12
