"""A toy ``GroupClearance`` for the core motion tests: a point robot in the plane (2 joints: its x
and y [m]) among discs, with closed-form distances (independent of coal and of the planner).

A pair is one disc: distance |q - c| - r. Over a step dq the point moves |dq|_2 <= |dq_1| + |dq_2|,
so ``motion_weights`` are ones (a true Lipschitz bound, as the Protocol asks).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Contact:
    time: float
    links: tuple[str, str]
    distance: float
    index: int


@dataclass(frozen=True)
class PathCheck:
    contact: Contact | None
    min_clearance: float
    closest: tuple[tuple[str, str], float] | None
    evaluations: int


class Discs:
    def __init__(self, centers: list[list[float]], radii: list[float], clearance: float = 0.0):
        self.centers = np.asarray(centers, dtype=float).reshape(-1, 2)
        self.radii = np.asarray(radii, dtype=float)
        P = len(self.radii)
        self.pair_names = [("point", f"disc{i}") for i in range(P)]
        self.threshold = np.full(P, clearance)
        self.motion_weights = np.ones((P, 2))
        self.evaluations = 0

    def distances(self, qs: np.ndarray) -> np.ndarray:
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        self.evaluations += len(qs)
        return np.linalg.norm(qs[:, None, :] - self.centers[None], axis=2) - self.radii

    def pair_distances(self, q: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        return self.distances(q)[0, pairs]

    def check_path(self, times: np.ndarray, qs: np.ndarray) -> PathCheck:
        """Exact continuous check (the point moves on straight segments between rows): the first
        time a disc is nearer than its threshold, and the smallest distance over the motion."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        t = np.asarray(times, dtype=float)
        if len(qs) == 1:
            qs, t = np.vstack([qs, qs]), np.r_[t, t]
        a, d = qs[:-1, None, :], np.diff(qs, axis=0)[:, None, :]  # (K, 1, 2)
        rel = a - self.centers[None]  # (K, P, 2)
        dd = np.maximum((d * d).sum(-1), 1e-300)
        u = np.clip(-(rel * d).sum(-1) / dd, 0.0, 1.0)  # closest point of each segment
        gap = np.linalg.norm(rel + u[..., None] * d, axis=-1) - self.radii  # (K, P)
        k, p = np.unravel_index(int(np.argmin(gap)), gap.shape)
        closest = (self.pair_names[p], float(t[k] + u[k, p] * (t[k + 1] - t[k])))
        contact = None
        hit = np.argwhere(gap < self.threshold)
        if len(hit):
            times_hit = []
            for kk, pp in hit:  # the first u where |rel + u d| = r + threshold
                A, B = dd[kk, 0], 2.0 * (rel[kk, pp] * d[kk, 0]).sum()
                C = (rel[kk, pp] ** 2).sum() - (self.radii[pp] + self.threshold[pp]) ** 2
                root = max(0.0, (-B - np.sqrt(max(B * B - 4 * A * C, 0.0))) / (2 * A))
                times_hit.append((t[kk] + min(root, 1.0) * (t[kk + 1] - t[kk]), kk, pp))
            time, kk, pp = min(times_hit)
            q = qs[kk] + (time - t[kk]) / max(t[kk + 1] - t[kk], 1e-300) * (qs[kk + 1] - qs[kk])
            dist = float(np.linalg.norm(q - self.centers[pp]) - self.radii[pp])
            contact = Contact(float(time), self.pair_names[pp], dist, int(kk))
        return PathCheck(contact, float(gap[k, p]), closest, gap.size)

    def close_pairs(self, q: np.ndarray, d_influence: float):
        d = self.distances(q)[0]
        near = np.flatnonzero(d < d_influence)
        gap = np.asarray(q, dtype=float) - self.centers[near]
        n2 = gap / np.linalg.norm(gap, axis=1, keepdims=True)
        normals = np.hstack([n2, np.zeros((len(near), 1))])
        jac = np.repeat(np.array([[[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]]), len(near), axis=0)
        return near, d[near], normals, jac

    def collides(self, q: np.ndarray, margin: float) -> bool:
        return bool((self.distances(q)[0] < self.threshold + margin).any())

    def closest_pair(self, q: np.ndarray):
        d = self.distances(q)[0]
        p = int(np.argmin(d - self.threshold))
        return self.pair_names[p], float(d[p]), float(self.threshold[p])


def min_margin_dense(clearance: Discs, knots: np.ndarray, per_segment: int = 2000) -> float:
    """Smallest margin over the thresholds along the straight segments through ``knots``, on a
    dense sweep (the independent reference of the certification tests)."""
    t = np.linspace(0.0, 1.0, per_segment)[:, None]
    qs = np.vstack([a + t * (b - a) for a, b in itertools.pairwise(knots)])
    d = np.linalg.norm(qs[:, None, :] - clearance.centers[None], axis=2) - clearance.radii
    return float((d - clearance.threshold).min())
