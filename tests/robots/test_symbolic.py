"""The CasADi forward kinematics equals pinocchio's, values and derivatives."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from robots import registry
from robots.symbolic import fk_casadi
from tests.robots.inline_urdfs import OFFSET_BASE_URDF


def robots_under_test():
    inline = registry.load_inline(OFFSET_BASE_URDF, "tool", "mount")
    return [registry.get(n) for n in registry.names()] + [inline]


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_casadi_fk_equals_pinocchio(robot) -> None:
    fk = fk_casadi(robot)
    assert fk_casadi(robot) is fk  # built once per robot
    rng = np.random.default_rng(0)
    lo, hi = np.clip(robot.position_limits.T, -4, 4)
    qs = rng.uniform(lo, hi, (300, robot.dof))
    batch = fk.map(len(qs))
    P, R = batch(qs.T)
    P = np.array(P).T
    R = np.array(R).reshape(3, len(qs), 3).transpose(1, 0, 2)  # map: [R_1 R_2 ... R_N], (3, 3N)
    T = np.array([robot.fk(q) for q in qs])
    worst = max(np.abs(P - T[:, :3, 3]).max(), np.abs(R - T[:, :3, :3]).max())
    assert worst <= 1e-9


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_casadi_jacobian_equals_pinocchio(robot) -> None:
    q = ca.SX.sym("q", robot.dof)
    p, _ = fk_casadi(robot)(q)
    Jp = ca.Function("Jp", [q], [ca.jacobian(p, q)])
    rng = np.random.default_rng(1)
    for _ in range(20):
        x = rng.uniform(*np.clip(robot.position_limits.T, -3, 3))
        assert np.abs(np.array(Jp(x)) - robot.jacobian(x)[:3]).max() <= 1e-9
