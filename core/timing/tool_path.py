"""The tool's speed along a joint path and its rate of change, from the Jacobian alone.

Along q(s) the tool point moves with v = J_v q_s s' and turns with w = J_w q_s s' (Jacobian in the
base frame, linear rows first). Its speed |v| = rho s' (rho = |J_v q_s|) changes at

    d|v|/dt = rho s'' + rho_s s'^2,   rho_s = (J_v q_s) . p_ss / rho,   p_ss = J_v q_ss + H(q_s, q_s),

where H(q_s, q_s) = (dJ/ds) q_s is the Jacobian's own change along the path. For a serial chain it
needs no more than the Jacobian's columns (Haviland and Corke, "Manipulator differential
kinematics, part II", IEEE RAM 2023, the kinematic Hessian): with the columns in chain order (a
joint before its children, as pinocchio numbers them), d J_v,i / d q_j = J_w,min(i,j) x
J_v,max(i,j), d J_w,i / d q_j = J_w,j x J_w,i for j < i and 0 otherwise (revolute and prismatic
joints alike: a prismatic column has J_w = 0). The same holds for the angular speed |w|. Where the
tool stands still (rho = 0) the rate is bounded by |p_ss| s'^2. Units: [m] and [rad] per unit s.
"""

from __future__ import annotations

import numpy as np

from core.kinematics import Kinematics, jacobians
from core.timing.path_constraints import ToolAccelerationRates

STILL = 1e-12
"""rho [m or rad per unit s] below which the tool counts as standing still."""


def jacobian_change(J: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """``(dJ/ds) dq`` ``(K, 6)`` for Jacobians ``J`` ``(K, 6, dof)`` moving along ``dq`` ``(K,
    dof)`` (the kinematic Hessian contracted twice with ``dq``; see the module docstring)."""
    V = J[:, :3, :] * dq[:, None, :]  # column i times dq_i
    W = J[:, 3:, :] * dq[:, None, :]
    before = np.cumsum(W, axis=2) - W  # sum over j < i of W_j
    after = np.cumsum(V[:, :, ::-1], axis=2)[:, :, ::-1]  # sum over j >= i of V_j
    linear = np.cross(before, V, axis=1).sum(axis=2) + np.cross(W, after, axis=1).sum(axis=2)
    angular = np.cross(before, W, axis=1).sum(axis=2)
    return np.concatenate([linear, angular], axis=1)


def speed_rates(J: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rho, rho_s)`` ``(K, 2)``: the tool's linear and angular speed per unit path speed and
    their derivatives along s, from the Jacobians ``J`` ``(K, 6, dof)`` and dq/ds, d2q/ds2."""
    rate = np.einsum("kij,kj->ki", J, dq)  # (K, 6): dp/ds and the turn per unit s
    change = np.einsum("kij,kj->ki", J, ddq) + jacobian_change(J, dq)  # d2p/ds2 ...
    rho = np.column_stack(
        [np.linalg.norm(rate[:, :3], axis=1), np.linalg.norm(rate[:, 3:], axis=1)]
    )
    dot = np.column_stack([
        np.einsum("ki,ki->k", rate[:, :3], change[:, :3]),
        np.einsum("ki,ki->k", rate[:, 3:], change[:, 3:]),
    ])  # fmt: skip
    size = np.column_stack(
        [np.linalg.norm(change[:, :3], axis=1), np.linalg.norm(change[:, 3:], axis=1)]
    )
    moving = rho > STILL
    rho_s = np.where(moving, dot / np.where(moving, rho, 1.0), size)
    return rho, rho_s


def tool_accelerations(kin: Kinematics) -> ToolAccelerationRates:
    """The ``ToolAccelerationRates`` of a robot (its tip Jacobian; see the module docstring)."""

    def rates(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return speed_rates(jacobians(kin, q), np.asarray(dq, float), np.asarray(ddq, float))

    return rates
