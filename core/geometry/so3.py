"""Quaternions, rotation matrices and poses (pure numpy; batched over leading axes).

Quaternions are in ROS order ``(x, y, z, w)``, unit norm. ``matrix_to_quat`` returns the
representative with ``w >= 0``. A pose is a position (3,) [m] and a quaternion; ``T`` is the 4x4
homogeneous transform.
"""

from __future__ import annotations

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
