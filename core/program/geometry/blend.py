"""Blends: the transition that replaces two neighbouring segments' parts inside a blend sphere.

Both parts are parameterized by u in [0, 1]: ``a(u)`` is the incoming segment from where it enters
the sphere (u = 0) to its goal (u = 1), ``c(u)`` the outgoing one from its start (u = 0) to where
it leaves the sphere (u = 1). The blend is ``(1 - w(u)) a(u) + w(u) c(u)`` with the quintic
smoothstep ``w = 10u^3 - 15u^4 + 6u^5`` (w' = w'' = 0 at both ends), so the blend has the position,
first and second derivatives of ``a`` at u = 0 and of ``c`` at u = 1: C2 where it meets each
segment. Positions mix linearly (inside the sphere, as both parts are), orientations along the
geodesic ``R_a exp(w log(R_a^T R_c))``. Cartesian-Cartesian blends mix poses (then IK), anything
with a PTP mixes joint positions.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from core.geometry import so3

CROSSING_SAMPLES = 2001
"""Samples of a path searched for where it crosses a sphere (then bisection to ``_BISECT``)."""
_BISECT = 60


def smoothstep(u: np.ndarray) -> np.ndarray:
    """Quintic weight 10u^3 - 15u^4 + 6u^5 on [0, 1]: zero slope and curvature at both ends."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u**2)


def _exp(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of rotation vectors (N, 3) (Rodrigues)."""
    angle = np.linalg.norm(rotvec, axis=1)
    safe = np.where(angle > 1e-12, angle, 1.0)
    k = rotvec / safe[:, None]
    K = np.zeros((len(rotvec), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _log(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (N, 3) of rotations (N, 3, 3): closed form away from a half turn, else
    ``core.line.rotvecs`` (the rows near pi)."""
    vee = 0.5 * np.stack(
        [R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1
    )
    cos = np.clip(0.5 * (np.trace(R, axis1=1, axis2=2) - 1.0), -1.0, 1.0)
    sin = np.linalg.norm(vee, axis=1)
    angle = np.arctan2(sin, cos)
    scale = np.where(sin > 1e-9, angle / np.where(sin > 1e-9, sin, 1.0), 1.0 + sin**2 / 6.0)
    out = vee * scale[:, None]
    far = cos < -0.9
    if far.any():
        out[far] = so3.log(R[far])
    return out


def pose_blend(
    a: Callable[[np.ndarray], np.ndarray], c: Callable[[np.ndarray], np.ndarray]
) -> Callable[[np.ndarray], np.ndarray]:
    """The blend of pose functions ``a(u)``, ``c(u)`` (u (N,) -> (N, 4, 4)): a pose function."""

    def poses(u: np.ndarray) -> np.ndarray:
        u = np.atleast_1d(np.asarray(u, dtype=float))
        w = smoothstep(u)
        Ta, Tc = a(u), c(u)
        T = np.zeros_like(Ta)
        T[:, :3, 3] = (1.0 - w)[:, None] * Ta[:, :3, 3] + w[:, None] * Tc[:, :3, 3]
        rel = _log(np.swapaxes(Ta[:, :3, :3], 1, 2) @ Tc[:, :3, :3])
        T[:, :3, :3] = Ta[:, :3, :3] @ _exp(w[:, None] * rel)
        T[:, 3, 3] = 1.0
        return T

    return poses


def joint_blend(
    a: Callable[[np.ndarray], np.ndarray], c: Callable[[np.ndarray], np.ndarray], u: np.ndarray
) -> np.ndarray:
    """Joint positions (N, dof) of the blend of joint paths ``a(u)``, ``c(u)`` at ``u`` (N,)."""
    w = smoothstep(u)[:, None]
    return (1.0 - w) * a(u) + w * c(u)


def sphere_crossing(
    positions: Callable[[np.ndarray], np.ndarray], center: np.ndarray, radius: float, last: bool
) -> float:
    """Path parameter s in [0, 1] where the path ``positions(s)`` (N,) -> (N, 3) crosses the sphere
    of ``radius`` [m] about ``center``: the last crossing inward (``last``: where the path enters
    the sphere about its end for good) or the first crossing outward (where it leaves the sphere
    about its start). Returns 1.0 (``last``) or 0.0 when the path never crosses."""
    s = np.linspace(0.0, 1.0, CROSSING_SAMPLES)
    outside = np.linalg.norm(positions(s) - center, axis=1) >= radius
    if last:
        idx = np.flatnonzero(outside)
        if len(idx) == 0 or idx[-1] == len(s) - 1:
            return 0.0 if len(idx) == 0 else 1.0
        lo, hi = s[idx[-1]], s[idx[-1] + 1]  # outside at lo, inside at hi
    else:
        idx = np.flatnonzero(outside)
        if len(idx) == 0 or idx[0] == 0:
            return 1.0 if len(idx) == 0 else 0.0
        lo, hi = s[idx[0] - 1], s[idx[0]]  # inside at lo, outside at hi
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        out = bool(np.linalg.norm(positions(np.array([mid]))[0] - center) >= radius)
        if out == last:
            lo = mid
        else:
            hi = mid
    return float(lo if last else hi)
