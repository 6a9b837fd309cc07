"""Blends: the transition that replaces two neighbouring segments' parts inside a blend sphere.

Both parts are parameterized by u in [0, 1]: ``a(u)`` is the incoming segment from where it enters
the sphere (u = 0) to its goal (u = 1), ``c(u)`` the outgoing one from its start (u = 0) to where
it leaves the sphere (u = 1). The blend is ``(1 - w(u)) a(u) + w(u) c(u)`` with the quintic
smoothstep ``w = 10u^3 - 15u^4 + 6u^5`` (the one quintic, ``core.timing.quintic``; w' and w''
zero at both ends), so the blend has the position, first and second derivatives of ``a`` at u = 0
and of ``c`` at u = 1: C2 where it meets each segment. Positions mix linearly (inside the sphere,
as both parts are), orientations along the geodesic ``R_a exp(w log(R_a^T R_c))``
(``core.geometry.so3``). Cartesian-Cartesian blends mix poses (``BlendPath``, a ``core.path.Path`` walked by ``core.cartesian.walk``), anything
with a PTP mixes joint positions (``joint_blend``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from core.geometry import so3
from core.path.base import PathDeviation
from core.timing.quintic import QuinticTiming

CROSSING_SAMPLES = 2001
"""Samples of a path searched for where it crosses a sphere (then ``_REFINE`` rounds of
``_SPLIT``-point k-section: the bracket 1/2000 x 16^-14, below a double's spacing)."""
_SPLIT = 15
_REFINE = 14
DERIVATIVE_STEP = 1e-6
"""Step in u of the central differences of ``BlendPath.derivative``."""
TABLE = 2001
"""Grid in u of the blend's tabulated poses and derivatives: ``deviation`` looks for the closest
point on it (then refines it), ``derivative`` interpolates it linearly (a relative error of
about 1e-7 for a blend's smooth turn)."""
REFINE_POINTS = 21
REFINE_ROUNDS = 2
"""Finer grids about the closest grid point (each 10 times finer: u to 5e-6 of the blend)."""

PoseFunction = Callable[[np.ndarray], np.ndarray]
"""Path parameters (N,) -> tool poses (N, 4, 4)."""
SMOOTHSTEP = QuinticTiming(1.0)
"""The blend weight w(u): the quintic rest-to-rest s(t) over a duration of 1."""


def smoothstep(u: np.ndarray) -> np.ndarray:
    """The quintic 10u^3 - 15u^4 + 6u^5 on [0, 1] (u clipped): ``QuinticTiming`` of duration 1."""
    return np.asarray(SMOOTHSTEP(np.asarray(u, dtype=float)), dtype=float)


def pose_blend(a: PoseFunction, c: PoseFunction) -> PoseFunction:
    """The blend of pose functions ``a(u)``, ``c(u)`` (u (N,) -> (N, 4, 4)): a pose function."""

    def poses(u: np.ndarray) -> np.ndarray:
        u = np.atleast_1d(np.asarray(u, dtype=float))
        w = smoothstep(u)
        Ta, Tc = a(u), c(u)
        T = np.zeros_like(Ta)
        T[:, :3, 3] = (1.0 - w)[:, None] * Ta[:, :3, 3] + w[:, None] * Tc[:, :3, 3]
        rel = so3.log(np.swapaxes(Ta[:, :3, :3], 1, 2) @ Tc[:, :3, :3])
        T[:, :3, :3] = Ta[:, :3, :3] @ so3.exp(w[:, None] * rel)
        T[:, 3, 3] = 1.0
        return T

    return poses


class BlendPath:
    """A Cartesian blend as a ``core.path.Path`` over u in [0, 1] (``pose_blend`` of the two
    parts), so the one IK walk of the Cartesian planners (``core.cartesian.walk``) walks it.

    Args:
        poses: The blend's pose function (``pose_blend``).
        task_space: ``"pose"`` or ``"position_xy"``.
    """

    def __init__(self, poses: PoseFunction, task_space: str = "pose") -> None:
        self._poses = poses
        self.task_space = task_space
        ends = poses(np.array([0.0, 1.0]))
        self.T_start, self.T_goal = ends[0], ends[1]
        grid = np.linspace(0.0, 1.0, TABLE)
        self._grid, self._grid_poses = grid, poses(grid)
        self._table = self._differences(grid)
        p = self._grid_poses[:, :3, 3]
        self._length = float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
        R = self._grid_poses[:, :3, :3]
        steps = so3.rotation_angle(np.swapaxes(R[:-1], 1, 2) @ R[1:])
        self._angle = float(np.sum(steps))

    @property
    def length(self) -> float:
        """Distance [m] the tool travels along the blend (polygon of ``DEVIATION_GRID`` poses)."""
        return self._length

    @property
    def angle(self) -> float:
        """Rotation [rad] the tool turns through along the blend."""
        return self._angle

    def poses(self, s: np.ndarray) -> np.ndarray:
        return self._poses(np.atleast_1d(np.asarray(s, dtype=float)))

    def pose(self, s: float) -> np.ndarray:
        return self._poses(np.array([s]))[0]

    def derivative(self, s: np.ndarray) -> np.ndarray:
        """``(N, 6)`` [dp/du, omega/du]: the tabulated central differences, interpolated."""
        s = np.clip(np.atleast_1d(np.asarray(s, dtype=float)), 0.0, 1.0)
        g, table = self._grid, self._table
        return np.stack([np.interp(s, g, table[:, k]) for k in range(6)], axis=1)

    def _differences(self, s: np.ndarray) -> np.ndarray:
        """``(N, 6)`` [dp/du, omega/du] by central differences (one-sided at the ends)."""
        h = DERIVATIVE_STEP
        lo = np.clip(s - h, 0.0, 1.0 - 2.0 * h)
        hi = lo + 2.0 * h
        A, B = self._poses(lo), self._poses(hi)
        span = 2.0 * h
        dp = (B[:, :3, 3] - A[:, :3, 3]) / span
        dw = so3.log(B[:, :3, :3] @ np.swapaxes(A[:, :3, :3], 1, 2)) / span
        return np.concatenate([dp, dw], axis=1)

    def deviation(
        self, T: np.ndarray, position_tolerance: float = 1e-3, orientation_tolerance: float = 1e-2
    ) -> PathDeviation:
        """Closest point of the blend to each pose of ``T`` (N, 4, 4), by position weighed against
        orientation by the tolerances: the best of a grid, refined on finer grids about it."""
        T = np.asarray(T, dtype=float).reshape(-1, 4, 4)

        def cost(P: np.ndarray, rows: np.ndarray) -> np.ndarray:
            dp = np.linalg.norm(P[:, :3, 3] - T[rows, :3, 3], axis=1) / position_tolerance
            if self.task_space == "position_xy":
                return dp
            rel = np.swapaxes(P[:, :3, :3], 1, 2) @ T[rows, :3, :3]
            return dp**2 + (so3.rotation_angle(rel) / orientation_tolerance) ** 2

        n, g = len(T), self._grid
        grid_cost = cost(np.tile(self._grid_poses, (n, 1, 1)), np.repeat(np.arange(n), len(g)))
        u = g[np.argmin(grid_cost.reshape(n, len(g)), axis=1)]
        width = g[1] - g[0]
        steps = np.linspace(-1.0, 1.0, REFINE_POINTS)
        for _ in range(REFINE_ROUNDS):  # a finer grid about the best point, twice
            cand = np.clip(u[:, None] + width * steps[None, :], 0.0, 1.0)
            c = cost(self._poses(cand.ravel()), np.repeat(np.arange(n), REFINE_POINTS))
            u = cand[np.arange(n), np.argmin(c.reshape(n, REFINE_POINTS), axis=1)]
            width *= 2.0 / (REFINE_POINTS - 1)
        P = self._poses(u)
        position = np.linalg.norm(P[:, :3, 3] - T[:, :3, 3], axis=1)
        orientation = np.zeros(n)
        if self.task_space != "position_xy":
            orientation = so3.rotation_angle(np.swapaxes(P[:, :3, :3], 1, 2) @ T[:, :3, :3])
        return PathDeviation(s=u, position=position, orientation=orientation)


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
    idx = np.flatnonzero(outside)
    if last:
        if len(idx) == 0 or idx[-1] == len(s) - 1:
            return 0.0 if len(idx) == 0 else 1.0
        lo, hi = s[idx[-1]], s[idx[-1] + 1]  # outside at lo, inside at hi
    else:
        if len(idx) == 0 or idx[0] == 0:
            return 1.0 if len(idx) == 0 else 0.0
        lo, hi = s[idx[0] - 1], s[idx[0]]  # inside at lo, outside at hi
    for _ in range(_REFINE):  # k-section: the bracket shrinks 1/(_SPLIT + 1) a round
        mid = lo + (hi - lo) * np.arange(1, _SPLIT + 1) / (_SPLIT + 1)
        out = np.linalg.norm(positions(mid) - center, axis=1) >= radius
        # the bracket keeps ``last`` (outside) at lo and ``not last`` at hi
        k = np.flatnonzero(out != last)
        j = int(k[0]) if len(k) else _SPLIT  # first point on hi's side
        lo, hi = (mid[j - 1] if j > 0 else lo), (mid[j] if j < _SPLIT else hi)
        if hi - lo <= 0.0:
            break
    return float(lo if last else hi)
