"""Joint rates along the path: dq/ds = J^+ V(s) and d2q/ds2, with the smallest singular value;
``predict``: where the integral curve of those rates leads (a redundant arm's IK seed).

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
EXACT_BELOW = 1e-2
"""``min_norm_rates`` takes the SVD where the smallest singular value is below this share of the
largest (the normal equations lose ~cond^2 eps there: 1e-12 relative at this bound)."""
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
    at: np.ndarray | float | None = s
    if at is None:
        ends = line.derivative(np.array([0.0, 1.0]))
        # A constant derivative (a line) needs no s; otherwise project the FK onto the path.
        at = 0.0 if np.array_equal(ends[0], ends[1]) else line.deviation(robot.fk_many(positions)).s
    s = np.broadcast_to(np.asarray(at, dtype=float), (len(positions),))

    def rates(
        qs: np.ndarray, at: np.ndarray, exact: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        J = jacobians(robot, qs)[:, rows]
        V = line.derivative(at)[:, rows]  # per unit s
        return min_norm_rates(J, V, exact)

    dq, sigma, exact = rates(positions, s, None)
    if not second_order:
        return PathRates(dq, np.zeros_like(dq), sigma)
    h = 1e-5 / np.maximum(np.abs(dq).max(axis=1), 1e-3)
    step = h[:, None] * dq
    ahead = rates(positions + step, s + h, exact)[0]  # (the same route as at the point)
    behind = rates(positions - step, s - h, exact)[0]
    return PathRates(dq, (ahead - behind) / (2.0 * h[:, None]), sigma)


def predict(
    robot: Kinematics, line: Path, q0: np.ndarray, dq0: np.ndarray, s0: np.ndarray, h: np.ndarray
) -> np.ndarray:
    """Joint positions ``(N, dof)`` a step ``h`` ``(N,)`` along the path from ``q0`` ``(N, dof)``
    at ``s0`` ``(N,)`` (``dq0``: the rates there): first order, ``q0 + dq0 h``, for an arm
    without redundancy (IK lands on the one solution near it); for a redundant arm the integral
    curve of dq/ds = J^+ V(s) by one classic Runge-Kutta step (3 more Jacobians per row), so that
    IK from it (whose corrections J^+ e leave the null space alone) keeps the returned positions on
    the curve the returned velocities J^+ V s' describe: with the first-order seed the null-space
    motion drifts off it by ~dq''h^2/2 a step (issue 26.9: 6.3e-3 rad/s on a Panda line)."""
    q0, dq0 = np.atleast_2d(q0), np.atleast_2d(dq0)
    s0, h = np.asarray(s0, dtype=float), np.asarray(h, dtype=float)
    first = q0 + dq0 * h[:, None]
    if robot.dof <= len(task_rows(robot.task_space)):
        return first

    def rates(q: np.ndarray, at: np.ndarray) -> np.ndarray:
        return path_rates(robot, line, q, second_order=False, s=at).dq_ds

    k2 = rates(q0 + 0.5 * h[:, None] * dq0, s0 + 0.5 * h)
    k3 = rates(q0 + 0.5 * h[:, None] * k2, s0 + 0.5 * h)
    k4 = rates(q0 + h[:, None] * k3, s0 + h)
    rk4 = q0 + h[:, None] / 6.0 * (dq0 + 2.0 * k2 + 2.0 * k3 + k4)
    # Near a singularity the midpoint rates can run away: keep the first order there.
    sane = np.all(np.isfinite(rk4), axis=1) & (
        np.abs(rk4 - first).max(axis=1) <= 0.5 * np.abs(first - q0).max(axis=1) + 1e-9
    )
    return np.where(sane[:, None], rk4, first)


def smallest_singular_values(J: np.ndarray) -> np.ndarray:
    """The smallest of the ``min(m, dof)`` singular values ``(N,)`` of each ``J`` ``(N, m, dof)``:
    from the eigenvalues of ``J J^T`` (about 2x cheaper than the SVD), by the SVD where it is below
    ``EXACT_BELOW`` of the largest (``min_norm_rates``'s test: relative error ~1e-12 either way)
    or ``m > dof``."""
    if J.shape[1] > J.shape[2]:
        return np.linalg.svd(J, compute_uv=False)[:, -1]
    return min_norm_rates(J, np.zeros(J.shape[:2]))[1]


def min_norm_rates(
    J: np.ndarray, V: np.ndarray, exact: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``J^+ V`` ``(N, dof)`` for Jacobians ``J`` ``(N, m, dof)`` and twists ``V`` ``(N, m)``, the
    smallest singular value of each ``J`` ``(N,)`` (zero when ``m > dof``) and which rows took the
    SVD ``(N,)``.

    Where ``J`` has full row rank, ``J^+ V = J^T (J J^T)^-1 V`` (``J^-1 V`` when square) by one
    batched solve, and the singular values are the roots of the eigenvalues of ``J J^T``: several
    times cheaper than the SVD of each ``J`` (0.4 against 3.6 ms for 600 UR5 Jacobians). The SVD (as
    ``np.linalg.pinv`` builds the pseudo-inverse, its cutoff ``PINV_RCOND``) takes the rows where
    that is not exact to ~1e-10: ``sigma_min`` below ``EXACT_BELOW`` of the largest, or ``m > dof``.
    Given ``exact`` (a previous call's, at nearby configurations) the rows take the routes it says
    and no singular values are computed (zeros).
    """
    n, m, dof = J.shape
    sigma, dq = np.zeros(n), np.zeros((n, dof))
    gram = J @ np.swapaxes(J, 1, 2) if m <= dof else None
    if exact is None:
        exact = np.ones(n, dtype=bool)
        if gram is not None:
            mu = np.linalg.eigvalsh(gram)
            low, high = np.sqrt(np.maximum(mu[:, 0], 0.0)), np.sqrt(np.maximum(mu[:, -1], 0.0))
            exact, sigma = low < EXACT_BELOW * np.maximum(high, 1e-300), low
    fast = ~exact
    if gram is not None and fast.any():
        if m == dof:
            dq[fast] = np.linalg.solve(J[fast], V[fast, :, None])[..., 0]
        else:
            x = np.linalg.solve(gram[fast], V[fast, :, None])
            dq[fast] = (np.swapaxes(J[fast], 1, 2) @ x)[..., 0]
    if exact.any():
        u, sv, vt = np.linalg.svd(J[exact], full_matrices=False)
        if m <= dof:
            sigma[exact] = sv[:, -1]
        large = sv > PINV_RCOND * sv.max(axis=-1, keepdims=True)
        inverse = np.divide(1.0, sv, where=large, out=np.zeros_like(sv))
        pinv = np.matmul(np.swapaxes(vt, -1, -2), inverse[..., None] * np.swapaxes(u, -1, -2))
        dq[exact] = np.einsum("nij,nj->ni", pinv, V[exact])
    return dq, sigma, exact
