"""Quaternions, rotation matrices and poses (pure numpy; batched over leading axes).

Quaternions are in ROS order ``(x, y, z, w)``, unit norm. ``matrix_to_quat`` returns the
representative with ``w >= 0``. A pose is a position (3,) [m] and a quaternion; ``T`` is the 4x4
homogeneous transform.
"""

from __future__ import annotations

import math

import numpy as np

QUAT_NORM_TOLERANCE = 1e-3
"""A quaternion whose norm is off 1 by more than this is rejected (API.md); else it is normalized."""


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of quaternions ``(..., 4)`` in (x, y, z, w) order.

    The quaternion is normalized first; a zero quaternion raises ``ValueError``.
    """
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n == 0.0):
        raise ValueError("a zero quaternion has no rotation")
    x, y, z, w = np.moveaxis(q / n, -1, 0)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    R = np.stack(
        [
            1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy),
            2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx),
            2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy),
        ],
        axis=-1,
    )  # fmt: skip
    return R.reshape((*q.shape[:-1], 3, 3))


def matrix_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` (x, y, z, w), ``w >= 0``, of rotation matrices ``(..., 3, 3)``.

    Shepperd's method: the largest of the four squared components sets the branch, so the result
    is accurate for every rotation (no division by a small number).
    """
    R = np.asarray(R, dtype=float)
    m = R.reshape(-1, 3, 3)
    tr = np.trace(m, axis1=1, axis2=2)
    d = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], tr], axis=1)
    k = np.argmax(d, axis=1)
    q = np.empty((m.shape[0], 4))
    for i in range(4):
        sel = k == i
        if not sel.any():
            continue
        s = m[sel]
        if i == 3:
            r = np.sqrt(1.0 + tr[sel])
            v = [s[:, 2, 1] - s[:, 1, 2], s[:, 0, 2] - s[:, 2, 0], s[:, 1, 0] - s[:, 0, 1]]
            q[sel] = np.stack([v[0] / (2 * r), v[1] / (2 * r), v[2] / (2 * r), 0.5 * r], axis=1)
        else:
            j, m2 = (i + 1) % 3, (i + 2) % 3
            r = np.sqrt(np.maximum(1.0 + s[:, i, i] - s[:, j, j] - s[:, m2, m2], 0.0))
            out = np.empty((s.shape[0], 4))
            out[:, i] = 0.5 * r
            out[:, j] = (s[:, j, i] + s[:, i, j]) / (2 * r)
            out[:, m2] = (s[:, m2, i] + s[:, i, m2]) / (2 * r)
            out[:, 3] = (s[:, m2, j] - s[:, j, m2]) / (2 * r)
            q[sel] = out
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.where(q[:, 3:4] < 0, -1.0, 1.0)
    return q.reshape((*R.shape[:-2], 4))


def pose_to_matrix(position: np.ndarray, quaternion: np.ndarray) -> np.ndarray:
    """``T`` (4, 4) from a position (3,) [m] and a quaternion (4,) (x, y, z, w)."""
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(quaternion)
    T[:3, 3] = np.asarray(position, dtype=float)
    return T


def matrix_to_pose(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (3,) [m] and quaternion (4,) (x, y, z, w), ``w >= 0``, of ``T`` (4, 4)."""
    T = np.asarray(T, dtype=float)
    return T[:3, 3].copy(), matrix_to_quat(T[:3, :3])


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Angle [rad] in [0, pi] of rotations ``(..., 3, 3)``: ``atan2(|sin|, cos)``, accurate near 0
    and near pi (unlike ``arccos((trace - 1) / 2)``). The angle between ``Ra`` and ``Rb`` is
    ``rotation_angle(Ra.T @ Rb)``."""
    R = np.asarray(R, dtype=float)
    v = np.stack(
        [R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]],
        axis=-1,
    )
    cos = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(0.5 * np.linalg.norm(v, axis=-1), cos)


# --- the one SO(3) log / exp / slerp -------------------------------------------------------------

SMALL_ANGLE = 1e-3
"""[rad] below this ``log`` and ``exp`` use their Taylor series (exact to ~1e-16 there)."""
SCALAR_LOG_MAX_ANGLE = 0.5 * math.pi
"""[rad] one matrix turning less than this takes ``log``'s scalar route (the axis from
``(R - R^T) / 2``, accurate to ~1e-16 there); beyond it, toward a half turn where that axis
vanishes, the quaternion route."""


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``(..., 3, 3)`` of vectors ``(..., 3)``: ``skew(v) @ u == v x u``."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    K = np.stack([z, -w, y, w, z, -x, -y, x, z], axis=-1)
    return K.reshape((*v.shape[:-1], 3, 3))


def log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` [rad], angle in [0, pi], of rotation matrices ``(..., 3, 3)``.

    Equal to ``scipy.spatial.transform.Rotation.from_matrix(R).as_rotvec()`` within ~1e-15 (the same
    construction: Markley's choice of the largest of four quaternion candidates, so half turns are
    exact), several times cheaper in numpy. One matrix within ``SCALAR_LOG_MAX_ANGLE`` takes a scalar
    route (``math``, a few us: the per-tick error of the rate controllers).
    """
    R = np.asarray(R, dtype=float)
    if R.shape == (3, 3):
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])  # 2 sin(a) axis
        sin = 0.5 * math.sqrt(w @ w)
        angle = math.atan2(sin, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0))
        if angle < SMALL_ANGLE:
            return 0.5 * (1.0 + angle * angle / 6.0 + 7.0 * angle**4 / 360.0) * w
        if angle <= SCALAR_LOG_MAX_ANGLE:
            return (0.5 * angle / sin) * w
    m = R.reshape(-1, 3, 3)
    d = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    trace = d.sum(axis=1)
    choice = np.argmax(np.column_stack([d, trace]), axis=1)
    quat = np.empty((len(m), 4))  # x, y, z, w
    quat[:, 0] = m[:, 2, 1] - m[:, 1, 2]
    quat[:, 1] = m[:, 0, 2] - m[:, 2, 0]
    quat[:, 2] = m[:, 1, 0] - m[:, 0, 1]
    quat[:, 3] = 1.0 + trace
    for i in range(3):
        rows = np.flatnonzero(choice == i)
        if rows.size:
            j, k = (i + 1) % 3, (i + 2) % 3
            Ri = m[rows]
            quat[rows, i] = 1.0 - trace[rows] + 2.0 * Ri[:, i, i]
            quat[rows, j] = Ri[:, j, i] + Ri[:, i, j]
            quat[rows, k] = Ri[:, k, i] + Ri[:, i, k]
            quat[rows, 3] = Ri[:, k, j] - Ri[:, j, k]
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    quat *= np.where(quat[:, 3:] < 0.0, -1.0, 1.0)
    xyz = quat[:, :3]
    half = np.arctan2(np.linalg.norm(xyz, axis=1), quat[:, 3])
    angle = 2.0 * half
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(
            angle <= SMALL_ANGLE,
            2.0 + angle**2 / 12.0 + 7.0 * angle**4 / 2880.0,
            angle / np.sin(half),
        )
    return (scale[:, None] * xyz).reshape((*R.shape[:-2], 3))


def exp(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``(..., 3)`` [rad] (Rodrigues)."""
    v = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(v, axis=-1)[..., None, None]
    K = skew(v)
    small = angle < SMALL_ANGLE
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(angle) / angle)
        b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(angle)) / angle**2)
    return np.eye(3) + a * K + b * (K @ K)


def slerp(R0: np.ndarray, rotvec: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Rotations ``(N, 3, 3)`` at fractions ``s`` (N,) of the turn ``rotvec`` (3,) [rad] from ``R0``
    (3, 3): ``R0 exp(s rotvec)``; with ``rotvec = log(R0^T R1)`` the shorter arc from R0 to R1.
    Rodrigues about the one axis: ``R0 + sin(s a) R0 [k] + (1 - cos(s a)) R0 [k]^2``."""
    s = np.atleast_1d(np.asarray(s, dtype=float))
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.broadcast_to(R0, (s.size, 3, 3)).copy()
    K = skew(np.asarray(rotvec, dtype=float) / angle)
    R0K, R0K2 = R0 @ K, R0 @ K @ K
    theta = (s * angle)[:, None, None]
    return R0 + np.sin(theta) * R0K + (1.0 - np.cos(theta)) * R0K2
