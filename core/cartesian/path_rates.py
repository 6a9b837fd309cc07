"""Joint rates along the path: dq/ds = J^+ V(s) and d2q/ds2, with the smallest singular value.

V(s) is the path's derivative at s (``Path.derivative``): constant along a line, turning with s on an
arc. The s of each configuration is given, or read off the path as the closest point of its forward
kinematics (``Path.deviation``: exact for configurations on the path).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.kinematics import Kinematics, jacobians, task_rows
from core.path import Path

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
    line: Path,
    positions: np.ndarray,
    second_order: bool = True,
    deadline: Deadline = NO_DEADLINE,
    s: np.ndarray | None = None,
) -> PathRates:
    """dq/ds = J^+ V(s) at each row of ``positions`` (N, dof), with V(s) the path's derivative per
    unit s (task rows only) at ``s`` (N,) (None: the closest path point of each row's FK);
    d2q/ds2 = d(J^+ V)/ds by a central difference along dq/ds, V taken at s -/+ h (2 more
    Jacobians per row). ``RATES_CHUNK`` rows at a time, ``deadline`` checked between chunks."""
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    if len(positions) > RATES_CHUNK:
        parts = []
        for i in range(0, len(positions), RATES_CHUNK):
            deadline.check("joint rates along the path")
            part_s = None if s is None else np.atleast_1d(s)[i : i + RATES_CHUNK]
            parts.append(
                path_rates(robot, line, positions[i : i + RATES_CHUNK], second_order, s=part_s)
            )
        return PathRates(*(np.concatenate(a) for a in zip(*parts, strict=True)))
    rows = task_rows(robot.task_space)
    if s is None:
        ends = line.derivative(np.array([0.0, 1.0]))
        # A constant derivative (a line) needs no s; otherwise project the FK onto the path.
        s = 0.0 if np.array_equal(ends[0], ends[1]) else line.deviation(robot.fk_many(positions)).s
    s = np.broadcast_to(np.asarray(s, dtype=float), (len(positions),))

    def rates(qs: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # One SVD gives the smallest singular value and the pseudo-inverse (as np.linalg.pinv
        # builds it, with its default cutoff of 1e-15 times the largest singular value).
        J = jacobians(robot, qs)[:, rows]
        u, sv, vt = np.linalg.svd(J, full_matrices=False)
        smallest = sv[:, -1] if sv.shape[1] == len(rows) else np.zeros(len(qs))
        large = sv > PINV_RCOND * sv.max(axis=-1, keepdims=True)
        inverse = np.divide(1.0, sv, where=large, out=np.zeros_like(sv))
        pinv = np.matmul(np.swapaxes(vt, -1, -2), inverse[..., None] * np.swapaxes(u, -1, -2))
        V = line.derivative(at)[:, rows]  # per unit s
        return np.einsum("nij,nj->ni", pinv, V), smallest

    dq, sigma = rates(positions, s)
    if not second_order:
        return PathRates(dq, np.zeros_like(dq), sigma)
    h = 1e-5 / np.maximum(np.abs(dq).max(axis=1), 1e-3)
    step = h[:, None] * dq
    ahead, _ = rates(positions + step, s + h)
    behind, _ = rates(positions - step, s - h)
    return PathRates(dq, (ahead - behind) / (2.0 * h[:, None]), sigma)
