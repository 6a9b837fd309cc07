"""Jacobians equal finite differences of FK; singular values and manipulability agree with J."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robots import registry
from tests.robots.inline_urdfs import OFFSET_BASE_URDF

H = 1e-6


def fd_jacobian(fk, q: np.ndarray) -> np.ndarray:
    """Central differences: linear rows from the position, angular rows from R(q+h) R(q-h)^T."""
    J = np.zeros((6, q.size))
    for i in range(q.size):
        dq = np.zeros(q.size)
        dq[i] = H
        Tp, Tm = fk(q + dq), fk(q - dq)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * H)
        J[3:, i] = Rotation.from_matrix(Tp[:3, :3] @ Tm[:3, :3].T).as_rotvec() / (2 * H)
    return J


def robots_under_test():
    inline = registry.load_inline(OFFSET_BASE_URDF, "tool", "mount")
    return [registry.get(n) for n in registry.names()] + [inline]


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_jacobian_equals_finite_differences(robot) -> None:
    rng = np.random.default_rng(1)
    lo, hi = np.maximum(robot.position_limits.T, -np.pi), np.minimum(robot.position_limits.T, np.pi)
    for _ in range(50):
        q = rng.uniform(lo[0], hi[1])
        J = robot.jacobian(q)
        assert J.shape == (6, robot.dof)
        err = np.abs(J - fd_jacobian(robot.fk, q)).max()
        assert err <= 1e-6, f"{robot.name}: Jacobian != finite differences at q={q.tolist()}"


@pytest.mark.parametrize("robot", robots_under_test(), ids=lambda r: r.name)
def test_singular_values_and_manipulability(robot) -> None:
    rng = np.random.default_rng(2)
    for _ in range(20):
        q = rng.uniform(*np.clip(robot.position_limits.T, -3, 3))
        J = robot.jacobian(q)
        rows = [0, 1] if robot.task_space == "position_xy" else list(range(6))
        s = robot.singular_values(q)
        assert s.shape == (len(rows),)
        assert np.all(np.diff(s) <= 0) and s[-1] >= 0
        det = np.linalg.det(J[rows] @ J[rows].T)
        assert robot.manipulability(q) == pytest.approx(np.sqrt(max(det, 0.0)), abs=1e-9)


def test_singular_configurations_have_zero_singular_value() -> None:
    ur5 = registry.get("ur5")
    q = np.array([0.3, -1.0, 1.2, -1.0, 0.0, 0.4])  # wrist singularity: q5 = 0
    assert ur5.singular_values(q)[-1] < 1e-9
    planar = registry.get("planar_2r")
    assert planar.singular_values(np.array([0.4, 0.0]))[-1] < 1e-12  # stretched out
    assert planar.manipulability(np.array([0.0, np.pi / 2])) == pytest.approx(0.8)  # l1 l2 |sin q2|
