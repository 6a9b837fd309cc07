"""Distances of (configuration, pair) entries, vectorized: closed forms in numpy where they exist,
coal where they do not.

Every pair is one robot shape against an obstacle or against another robot shape, and gets one
method when the checker is built:

* ``SEGMENTS``: capsule (or sphere) against a capsule or a sphere: segment-segment distance minus the
  radii (Ericson's closed form).
* ``CAPSULE_HALFSPACE``: the lower end of the segment minus the radius.
* ``SOLID_HALFSPACE``: a box's or a cylinder's support point along the halfspace normal.
* ``SDF``: a capsule (or sphere) against a box or a cylinder: the minimum of the solid's signed
  distance function along the segment, which is convex along it (golden-section search), minus the
  radius; for a sphere, the signed distance function at its centre minus the radius (closed form).
* ``COAL``: a box or a cylinder against a box or a cylinder: coal's GJK/EPA, one call per entry
  (``coal.distance``, about 5 us).

``SDF`` and ``COAL`` entries cost more: given a ``floor``, an entry whose enclosing capsules are at
least ``max(largest threshold, min(floor, the smallest cheap distance of the call))`` apart keeps
that lower bound instead (it can be neither a contact nor the smallest distance, and a lower bound
keeps every interval bound of the continuous check valid).

Positions are in the model's world frame (the root joint's frame): obstacles are moved there once.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import coal
import numpy as np

from robots.collision.shapes import BOX, CAPSULE, CYLINDER, Obstacle, RobotCollision
from robots.geometry.distance import sdf_box, sdf_cylinder, segment_sdf_min, segment_segment

SEGMENTS, CAPSULE_HALFSPACE, SOLID_HALFSPACE, SDF, COAL = range(5)
GJK_TOLERANCE = 1e-9
"""[m] coal's GJK tolerance for box and cylinder pairs (its default 1e-6 overstated distances by up
to 1.3e-6 m); the result is lowered by it, so it stays a lower bound."""


@dataclass(frozen=True)
class Solid:
    """Shapes in a common form: a frame (centre, axes), ``kind`` (``CAPSULE``, ``BOX`` or
    ``CYLINDER``, spheres are capsules) and ``dims`` as in ``RobotCollision``; and an enclosing
    capsule ``a``-``b``, ``radius`` (in the frame the shapes are given in)."""

    kind: np.ndarray
    R: np.ndarray
    t: np.ndarray
    dims: np.ndarray
    a: np.ndarray
    b: np.ndarray
    radius: np.ndarray


def coal_shape(kind: int, dims: np.ndarray) -> coal.ShapeBase:
    if kind == BOX:
        return coal.Box(*(2 * dims))
    if kind == CYLINDER:
        return coal.Cylinder(float(dims[0]), float(2 * dims[1]))
    if dims[1] > 0:
        return coal.Capsule(float(dims[0]), float(2 * dims[1]))
    return coal.Sphere(float(dims[0]))


def obstacle_solids(obstacles: tuple[Obstacle, ...], T_world_base: np.ndarray) -> Solid:
    """The non-halfspace obstacles in the world frame (halfspace rows are placeholders)."""
    kind, R, t, dims, a, b, r = [], [], [], [], [], [], []
    for o in obstacles:
        T = T_world_base @ o.T_base_obstacle
        if o.shape == "box":
            half = np.resize(np.array(o.size, dtype=float), 3) / 2
            k, d, cap_r = BOX, half, float(np.linalg.norm(half))
            e = np.zeros(3)
        elif o.shape == "cylinder":
            k, d = CYLINDER, np.array([o.radius, o.length / 2, 0.0])
            e = np.array([0.0, 0.0, max(o.length / 2 - o.radius, 0.0)])
            cap_r = math.hypot(o.radius, min(o.radius, o.length / 2))
        else:  # sphere, capsule (and halfspace placeholders)
            h = o.length / 2 if o.shape == "capsule" else 0.0
            k, d, cap_r = CAPSULE, np.array([o.radius, h, 0.0]), o.radius
            e = np.array([0.0, 0.0, h])
        kind.append(k)
        R.append(T[:3, :3])
        t.append(T[:3, 3])
        dims.append(d)
        a.append(T[:3, 3] - T[:3, :3] @ e)
        b.append(T[:3, 3] + T[:3, :3] @ e)
        r.append(cap_r)
    n = len(obstacles)
    return Solid(
        np.array(kind, dtype=int),
        np.reshape(R, (n, 3, 3)),
        np.reshape(t, (n, 3)),
        np.reshape(dims, (n, 3)),
        np.reshape(a, (n, 3)),
        np.reshape(b, (n, 3)),
        np.array(r, dtype=float),
    )


def _solid_sdf(kind: int, dims: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The signed distance function of boxes (half edges ``dims``) or cylinders (``radius, half
    length``), one per row, in their own frames."""
    if kind == BOX:
        return lambda x: sdf_box(x, dims)
    return lambda x: sdf_cylinder(x, dims[:, 0], dims[:, 1])


def _method(kind1: int, kind2: int) -> int:
    """The method of a pair of shape kinds (obstacle halfspaces are handled by the caller)."""
    if kind1 == CAPSULE and kind2 == CAPSULE:
        return SEGMENTS
    if kind1 == CAPSULE or kind2 == CAPSULE:
        return SDF
    return COAL


class PairDistances:
    """The distance engine of one checker.

    Args:
        geometry: The robot's shapes (joint frames).
        obstacles: In the base frame.
        T_world_base: ``(4, 4)`` the base frame in the model's world frame.
        obs_pairs: ``(shape, obstacle)`` index pairs, then ``self_pairs`` ``(shape, shape)``.
        threshold: ``(P,)`` [m] per pair (the screening level is at least its largest value).
    """

    def __init__(
        self,
        geometry: RobotCollision,
        obstacles: tuple[Obstacle, ...],
        T_world_base: np.ndarray,
        obs_pairs: list[tuple[int, int]],
        self_pairs: list[tuple[int, int]],
        threshold: np.ndarray,
    ) -> None:
        g = geometry
        self.geometry = g
        self.obstacles = obstacle_solids(obstacles, T_world_base)
        hs = [k for k, o in enumerate(obstacles) if o.shape == "halfspace"]
        R_wb, t_wb = T_world_base[:3, :3], T_world_base[:3, 3]
        self._normal = np.zeros((len(obstacles), 3))
        self._offset = np.zeros(len(obstacles))
        for k in hs:
            n_w = R_wb @ np.array(obstacles[k].normal, dtype=float)
            self._normal[k], self._offset[k] = n_w, obstacles[k].offset + float(n_w @ t_wb)
        halfspace = np.array([o.shape == "halfspace" for o in obstacles], dtype=bool)
        self.n_obs = len(obs_pairs)
        pairs = obs_pairs + self_pairs
        self.first = np.array([i for i, _ in pairs], dtype=int)
        self.second = np.array([k for _, k in pairs], dtype=int)
        self.is_obs = np.arange(len(pairs)) < self.n_obs
        method = []
        for p, (i, k) in enumerate(pairs):
            k2 = int(self.obstacles.kind[k] if p < self.n_obs else g.kind[k])
            if p < self.n_obs and halfspace[k]:
                method.append(CAPSULE_HALFSPACE if g.kind[i] == CAPSULE else SOLID_HALFSPACE)
            else:
                method.append(_method(int(g.kind[i]), k2))
        self.method = np.array(method, dtype=int)
        self.threshold_max = float(threshold.max()) if len(threshold) else 0.0
        self._robot_coal = [coal_shape(int(g.kind[i]), g.dims[i]) for i in range(len(g.links))]
        self._obstacle_coal = [
            coal_shape(int(self.obstacles.kind[k]), self.obstacles.dims[k])
            for k in range(len(obstacles))
        ]
        self._request = coal.DistanceRequest()
        self._request.gjk_tolerance = GJK_TOLERANCE
        self.expensive = np.isin(self.method, (SDF, COAL))
        """``(P,)`` pairs whose exact distance is not a closed form (screened by a lower bound)."""

    # --- world geometry of the entries ----------------------------------------------------------
    def _robot_capsules(
        self, Rw: np.ndarray, pw: np.ndarray, c: np.ndarray, i: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """World ends ``(E, 3)`` twice of robot shapes ``i``' (enclosing) capsules at configs ``c``."""
        g = self.geometry
        j = g.joints[i]
        R, t = Rw[j, c], pw[j, c]
        a = np.einsum("eij,ej->ei", R, g.a[i]) + t
        b = np.einsum("eij,ej->ei", R, g.b[i]) + t
        return a, b

    def _capsules(
        self, Rw: np.ndarray, pw: np.ndarray, c: np.ndarray, p: np.ndarray
    ) -> tuple[np.ndarray, ...]:
        """Both sides' (enclosing) capsules of every entry: ``a1, b1, r1, a2, b2, r2``. Every shape at
        every configuration at once when that is no more than twice the entries (configurations
        shared by many pairs), else per entry."""
        g, o = self.geometry, self.obstacles
        G, U, E = len(g.links), Rw.shape[1], len(p)
        i, k, obs = self.first[p], self.second[p], self.is_obs[p]
        if U * G <= 2 * E:
            R, t = Rw[g.joints], pw[g.joints]  # (G, U, 3, 3), (G, U, 3)
            ends_a = np.einsum("guij,gj->ugi", R, g.a) + t.transpose(1, 0, 2)
            ends_b = np.einsum("guij,gj->ugi", R, g.b) + t.transpose(1, 0, 2)
            table_a = np.concatenate([ends_a.reshape(U * G, 3), o.a])
            table_b = np.concatenate([ends_b.reshape(U * G, 3), o.b])
            table_r = np.concatenate([np.tile(g.radius, U), o.radius])
            first = c * G + i
            second = np.where(obs, U * G + k, c * G + k)
            return (table_a[first], table_b[first], table_r[first],
                    table_a[second], table_b[second], table_r[second])  # fmt: skip
        a1, b1 = self._robot_capsules(Rw, pw, c, i)
        a2, b2, r2 = np.empty((E, 3)), np.empty((E, 3)), np.empty(E)
        e = np.flatnonzero(obs)
        a2[e], b2[e], r2[e] = o.a[k[e]], o.b[k[e]], o.radius[k[e]]
        e = np.flatnonzero(~obs)
        a2[e], b2[e] = self._robot_capsules(Rw, pw, c[e], k[e])
        r2[e] = g.radius[k[e]]
        return a1, b1, g.radius[i], a2, b2, r2

    def _robot_frames(
        self, Rw: np.ndarray, pw: np.ndarray, c: np.ndarray, i: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """World frames (rotations ``(E, 3, 3)``, centres ``(E, 3)``) of robot shapes ``i``."""
        g = self.geometry
        j = g.joints[i]
        R, t = Rw[j, c], pw[j, c]
        F = g.frames[i]
        return R @ F[:, :3, :3], np.einsum("eij,ej->ei", R, F[:, :3, 3]) + t

    def _second_frames(
        self, Rw: np.ndarray, pw: np.ndarray, c: np.ndarray, p: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The second side's frames, kinds and dims of each entry."""
        k, o, g, E = self.second[p], self.obstacles, self.geometry, len(p)
        R, t = np.empty((E, 3, 3)), np.empty((E, 3))
        kind, dims = np.empty(E, dtype=int), np.empty((E, 3))
        e = np.flatnonzero(self.is_obs[p])
        R[e], t[e], kind[e], dims[e] = o.R[k[e]], o.t[k[e]], o.kind[k[e]], o.dims[k[e]]
        e = np.flatnonzero(~self.is_obs[p])
        R[e], t[e] = self._robot_frames(Rw, pw, c[e], k[e])
        kind[e], dims[e] = g.kind[k[e]], g.dims[k[e]]
        return R, t, kind, dims

    # --- distances --------------------------------------------------------------------------------
    def __call__(
        self,
        Rw: np.ndarray,
        pw: np.ndarray,
        c: np.ndarray,
        p: np.ndarray,
        floor: float | None = None,
    ) -> np.ndarray:
        """Signed distances [m] of pairs ``p`` (E,) at configurations ``c`` (E,), indices into the
        joint placements ``Rw`` ``(J+1, N, 3, 3)``, ``pw`` ``(J+1, N, 3)``. Exact without a
        ``floor``; with one, expensive entries may keep a lower bound (module docstring)."""
        out = np.empty(len(p))
        method = self.method[p]
        a1, b1, r1, a2, b2, r2 = self._capsules(Rw, pw, c, p)
        half = np.isin(method, (CAPSULE_HALFSPACE, SOLID_HALFSPACE))
        m = np.flatnonzero(method == CAPSULE_HALFSPACE)
        if len(m):
            n_, off = self._normal[self.second[p[m]]], self._offset[self.second[p[m]]]
            low = np.minimum(np.einsum("ei,ei->e", a1[m], n_), np.einsum("ei,ei->e", b1[m], n_))
            out[m] = low - off - r1[m]
        m = np.flatnonzero(method == SOLID_HALFSPACE)
        if len(m):
            out[m] = self._solid_halfspace(Rw, pw, c[m], p[m])
        pairs = np.flatnonzero(~half)
        if len(pairs) == 0:
            return out
        d, _, _ = segment_segment(a1[pairs], b1[pairs], a2[pairs], b2[pairs])
        out[pairs] = d - r1[pairs] - r2[pairs]  # exact for SEGMENTS, a lower bound otherwise
        hard = pairs[self.expensive[p[pairs]]]
        if len(hard) == 0:
            return out
        if floor is not None:
            done = np.ones(len(p), dtype=bool)
            done[hard] = False
            level = min(floor, float(out[done].min()) if done.any() else math.inf)
            level = max(level, self.threshold_max)
            hard = hard[out[hard] < level]
        sdf = hard[method[hard] == SDF]
        if len(sdf):
            out[sdf] = self._sdf(
                Rw, pw, c[sdf], p[sdf], a1[sdf], b1[sdf], a2[sdf], b2[sdf], r2[sdf]
            )
        exact = hard[method[hard] == COAL]
        if len(exact):
            out[exact] = self._coal(Rw, pw, c[exact], p[exact])
        return out

    def _solid_halfspace(
        self, Rw: np.ndarray, pw: np.ndarray, c: np.ndarray, p: np.ndarray
    ) -> np.ndarray:
        """A robot box's or cylinder's signed distance to a halfspace: its lowest point along the
        normal (support function) minus the offset."""
        i, k = self.first[p], self.second[p]
        R, t = self._robot_frames(Rw, pw, c, i)
        n_, off = self._normal[k], self._offset[k]
        along = np.einsum("eij,ei->ej", R, n_)  # the normal in the shape's axes
        d = self.geometry.dims[i]
        box = self.geometry.kind[i] == BOX
        reach = np.where(
            box,
            np.einsum("ej,ej->e", np.abs(along), d),
            d[:, 1] * np.abs(along[:, 2])
            + d[:, 0] * np.sqrt(np.maximum(0.0, 1 - along[:, 2] ** 2)),
        )
        return np.einsum("ei,ei->e", t, n_) - reach - off

    def _sdf(
        self,
        Rw: np.ndarray,
        pw: np.ndarray,
        c: np.ndarray,
        p: np.ndarray,
        a1: np.ndarray,
        b1: np.ndarray,
        a2: np.ndarray,
        b2: np.ndarray,
        r2: np.ndarray,
    ) -> np.ndarray:
        """Capsule against box or cylinder: the solid's signed distance function minimized along
        the capsule's segment (expressed in the solid's frame), minus the capsule's radius. The
        capsule is the first side (``a1``, ``b1``) or the second (``a2``, ``b2``, ``r2``)."""
        g = self.geometry
        i = self.first[p]
        first_solid = g.kind[i] != CAPSULE
        out = np.empty(len(p))
        R, t, kind, dims = self._second_frames(Rw, pw, c, p)
        a, b, r = a1.copy(), b1.copy(), g.radius[i].copy()
        f = np.flatnonzero(first_solid)
        if len(f):
            a[f], b[f], r[f] = a2[f], b2[f], r2[f]
            R[f], t[f] = self._robot_frames(Rw, pw, c[f], i[f])
            kind[f], dims[f] = g.kind[i[f]], g.dims[i[f]]
        al = np.einsum("eji,ej->ei", R, a - t)  # R^T (a - t)
        bl = np.einsum("eji,ej->ei", R, b - t)
        point = np.all(a == b, axis=1)  # a sphere: the solid's sdf at its centre, closed form
        for solid in (BOX, CYLINDER):
            for m in (
                np.flatnonzero((kind == solid) & point),
                np.flatnonzero((kind == solid) & ~point),
            ):
                if not len(m):
                    continue
                sdf = _solid_sdf(solid, dims[m])
                out[m] = sdf(al[m]) if point[m[0]] else segment_sdf_min(al[m], bl[m], sdf)
        return out - r

    def _coal(self, Rw: np.ndarray, pw: np.ndarray, c: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Box or cylinder against box or cylinder: coal, one call per entry."""
        i = self.first[p]
        R1, t1 = self._robot_frames(Rw, pw, c, i)
        R2, t2, _, _ = self._second_frames(Rw, pw, c, p)
        out = np.empty(len(p))
        shapes2 = [
            self._obstacle_coal[k] if obs else self._robot_coal[k]
            for k, obs in zip(self.second[p].tolist(), self.is_obs[p].tolist(), strict=True)
        ]
        request, result, robot = self._request, coal.DistanceResult(), self._robot_coal
        for e, (k, s2) in enumerate(zip(i.tolist(), shapes2, strict=True)):
            result.clear()
            out[e] = coal.distance(
                robot[k],
                coal.Transform3s(R1[e], t1[e]),
                s2,
                coal.Transform3s(R2[e], t2[e]),
                request,
                result,
            )
        return out - GJK_TOLERANCE
