"""Joint rates along the line: dq/ds = J^+ V and d2q/ds2, with the smallest singular value."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.kinematics import Kinematics, jacobians, task_rows
from core.path.line import StraightLine

RATES_CHUNK = 2048
"""Rows of ``path_rates`` computed between two deadline checks."""
PINV_RCOND = 1e-15
"""Singular values below this share of the largest are dropped from J^+ (np.linalg.pinv's default)."""


class PathRates(NamedTuple):
    """Derivatives of the path q(s) at configurations on the line.

    Attributes:
        dq_ds: ``(N, dof)`` J^+ V [rad per unit s].
        d2q_ds2: ``(N, dof)`` its derivative along the path [rad per unit s^2] (zeros if not asked).
        sigma: ``(N,)`` smallest singular value of the task Jacobian.
    """

    dq_ds: np.ndarray
    d2q_ds2: np.ndarray
    sigma: np.ndarray


def path_rates(
    robot: Kinematics,
    line: StraightLine,
    positions: np.ndarray,
    second_order: bool = True,
    deadline: Deadline = NO_DEADLINE,
) -> PathRates:
    """dq/ds = J^+ V at each row of ``positions`` (N, dof), with V the line's twist per unit s (task
    rows only); d2q/ds2 by a central difference of J^+ V along dq/ds (2 more Jacobians per row).
    ``RATES_CHUNK`` rows at a time, ``deadline`` checked between chunks."""
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    if len(positions) > RATES_CHUNK:
        parts = []
        for i in range(0, len(positions), RATES_CHUNK):
            deadline.check("joint rates along the line")
            parts.append(path_rates(robot, line, positions[i : i + RATES_CHUNK], second_order))
        return PathRates(*(np.concatenate(a) for a in zip(*parts, strict=True)))
    rows = task_rows(robot.task_space)
    V = line.derivative(np.zeros(1))[0][rows]  # per unit s (constant along a line)

    def rates(qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # One SVD gives the smallest singular value and the pseudo-inverse (as np.linalg.pinv
        # builds it, with its default cutoff of 1e-15 times the largest singular value).
        J = jacobians(robot, qs)[:, rows]
        u, sv, vt = np.linalg.svd(J, full_matrices=False)
        smallest = sv[:, -1] if sv.shape[1] == len(rows) else np.zeros(len(qs))
        large = sv > PINV_RCOND * sv.max(axis=-1, keepdims=True)
        inverse = np.divide(1.0, sv, where=large, out=np.zeros_like(sv))
        pinv = np.matmul(np.swapaxes(vt, -1, -2), inverse[..., None] * np.swapaxes(u, -1, -2))
        return np.einsum("nij,j->ni", pinv, V), smallest

    dq, sigma = rates(positions)
    if not second_order:
        return PathRates(dq, np.zeros_like(dq), sigma)
    h = 1e-5 / np.maximum(np.abs(dq).max(axis=1), 1e-3)
    step = h[:, None] * dq
    ahead, _ = rates(positions + step)
    behind, _ = rates(positions - step)
    return PathRates(dq, (ahead - behind) / (2.0 * h[:, None]), sigma)
