"""``CollisionChecker``: the pairs of one robot in one work cell, and their distances for many
configurations (``core.clearance.Clearance``).

Obstacle pairs are every robot shape not fixed to the model's root (the base stands on its mount)
against every obstacle; self pairs are shapes of different links not in the allowed pairs. Pairs are
ordered obstacle pairs first, then self pairs (``pair_names``). Distances come from
``robots.collision.entries`` (numpy closed forms, coal for box and cylinder pairs), the continuous
check from ``robots.collision.continuous``, single configurations with witness points from coal through
pinocchio's ``GeometryModel`` (``robots.collision.coal_model``).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pinocchio as pin

from robots.collision.coal_model import build as build_geometry_model
from robots.collision.coal_model import closest_pairs
from robots.collision.continuous import ENTRY_CHUNK, PathCheck, check_path
from robots.collision.dampers import damper_inputs
from robots.collision.entries import PairDistances
from robots.collision.motion_bound import motion_weights
from robots.collision.shapes import Obstacle, RobotCollision
from robots.geometry.joints import JointPlacements
from robots.model import Robot


class CollisionChecker:
    """Distances between a robot's shapes, obstacles and its own links, for many configurations.

    Args:
        robot: The robot (its pinocchio model carries the joints).
        geometry: Its shapes (``robot_collision``).
        obstacles: In the base frame; names must differ from each other and from link names.
        clearance: [m] >= 0: obstacles closer than this are a contact.
        self_collision: Check pairs of the robot's own links (those not in ``allowed_self``).
        allowed: Extra pairs of names (link/link or link/obstacle) never checked.
        allowed_self: Link pairs that are never checked for self-collision (``allowed_self_pairs``).
    """

    def __init__(
        self,
        robot: Robot,
        geometry: RobotCollision,
        obstacles: Sequence[Obstacle] = (),
        *,
        clearance: float = 0.0,
        self_collision: bool = True,
        allowed: Sequence[tuple[str, str]] = (),
        allowed_self: frozenset[frozenset[str]] = frozenset(),
    ) -> None:
        self.robot, self.geometry, self.obstacles = robot, geometry, tuple(obstacles)
        self._joints = JointPlacements.from_model(robot.model)
        self._T_base_world = robot.chain.T_base_world
        skip = {frozenset(p) for p in allowed} | set(allowed_self)
        g = geometry
        G = len(g.links)
        self._obs_pairs = [
            (i, k)
            for k, o in enumerate(self.obstacles)
            for i in range(G)
            if g.joints[i] != 0 and frozenset((g.links[i], o.name)) not in skip
        ]
        self._self_pairs = [
            (i, j)
            for i, j in itertools.combinations(range(G), 2)
            if self_collision
            and g.links[i] != g.links[j]
            and frozenset((g.links[i], g.links[j])) not in skip
        ]
        self.pair_names: list[tuple[str, str]] = [
            (g.links[i], self.obstacles[k].name) for i, k in self._obs_pairs
        ] + [(g.links[i], g.links[j]) for i, j in self._self_pairs]
        self.threshold = np.array(
            [clearance] * len(self._obs_pairs) + [0.0] * len(self._self_pairs)
        )
        self._weights = motion_weights(
            self._joints, g, robot.position_limits, self._obs_pairs, self._self_pairs
        )
        T_world_base = np.linalg.inv(self._T_base_world)
        self._pairs = PairDistances(
            g, self.obstacles, T_world_base, self._obs_pairs, self._self_pairs, self.threshold
        )
        self._coal: tuple[Any, ...] | None = None  # damper_inputs' workspace, built on first use

    @property
    def n_pairs(self) -> int:
        return len(self.pair_names)

    @property
    def motion_weights(self) -> np.ndarray:
        """``core.clearance.Clearance.motion_weights``: ``(P, dof)``, a pair's distance changes by
        at most ``motion_weights @ |dq|`` [m] over a linear joint step ``dq``."""
        return self._weights

    # --- distances ----------------------------------------------------------------------------
    def _evaluate(
        self, qs: np.ndarray, c: np.ndarray, p: np.ndarray, floor: float | None = None
    ) -> np.ndarray:
        """Distances of pairs ``p`` (E,) at rows ``c`` (E,) of ``qs`` (U, dof) (see
        ``PairDistances``: with a ``floor``, expensive entries may keep a lower bound)."""
        Rw, pw = self._joints.placements(qs)
        return self._pairs(Rw, pw, c, p, floor)

    def distances(self, qs: np.ndarray) -> np.ndarray:
        """Signed distances ``(N, P)`` [m] of every checked pair (``pair_names`` order) for each row of
        ``qs`` ``(N, dof)``; negative: penetration. Exact (no bounds), in chunks of bounded memory."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        n, P = qs.shape[0], self.n_pairs
        out = np.empty((n, P))
        if P == 0:
            return out
        rows = max(1, ENTRY_CHUNK // P)
        for k in range(0, n, rows):
            block = qs[k : k + rows]
            m = len(block)
            for s in range(0, m * P, ENTRY_CHUNK):  # a row may hold more pairs than one chunk
                e = np.arange(s, min(s + ENTRY_CHUNK, m * P))
                out[k : k + m].reshape(-1)[e] = self._evaluate(block, e // P, e % P)
        return out

    def min_distances(self, qs: np.ndarray) -> np.ndarray:
        """Smallest signed distance ``(N,)`` [m] over every checked pair for each row of ``qs``
        ``(N, dof)``: ``distances(qs).min(axis=1)``, exact, but box and cylinder entries whose
        enclosing-capsule lower bound is not below the row's smallest exact distance are skipped."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        n, P = qs.shape[0], self.n_pairs
        out = np.full(n, math.inf)
        costly = self._pairs.expensive
        rows = max(1, ENTRY_CHUNK // max(P, 1))
        for k in range(0, n, rows):
            block = qs[k : k + rows]
            m = len(block)
            r, p = np.repeat(np.arange(m), P), np.tile(np.arange(P), m)
            d = self._evaluate(block, r, p, -math.inf)  # expensive entries: exact or a bound
            best = np.full(m, math.inf)
            np.minimum.at(best, r[~costly[p]], d[~costly[p]])
            todo = np.flatnonzero(costly[p])
            # the entry with the smallest bound of each row first, then whatever may still win
            for stage in range(2):
                todo = todo[d[todo] < best[r[todo]]]
                if stage == 0 and len(todo):
                    order = todo[np.lexsort((d[todo], r[todo]))]
                    pick = order[np.r_[True, r[order][1:] != r[order][:-1]]]
                else:
                    pick = todo
                if len(pick):
                    d[pick] = self._evaluate(block, r[pick], p[pick])
                    np.minimum.at(best, r[pick], d[pick])
                    todo = np.setdiff1d(todo, pick)
            out[k : k + m] = best
        return out

    def check_path(self, times: np.ndarray, qs: np.ndarray) -> PathCheck:
        """Continuous check of the motion through ``qs`` ``(N, dof)`` at ``times`` ``(N,)`` [s],
        joints moving linearly between consecutive rows: the first contact and a certified
        ``min_clearance`` (``robots.collision.continuous``); working memory at most
        ``robots.collision.continuous.CHECK_WORKING_BYTES`` beyond the inputs."""
        return check_path(times, qs, self._evaluate, self.threshold, self._weights, self.pair_names)

    def close_pairs(
        self, q: np.ndarray, d_influence: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``core.clearance.Clearance.close_pairs``: ``damper_inputs`` as a tuple."""
        d = damper_inputs(self, q, d_influence)
        return d.pairs, d.distances, d.normals, d.point_jacobians

    # --- one configuration, with coal ---------------------------------------------------------
    def geometry_model(self) -> tuple[pin.GeometryModel, list[tuple[str, str]]]:
        """A pinocchio ``GeometryModel`` of the robot's shapes (exact: coal capsules, spheres, boxes,
        cylinders) and the obstacles, with one collision pair per checked pair, and the names of each
        of ``gm.collisionPairs`` in that order (usable with ``pin.computeCollisions`` and
        ``pin.computeDistances``)."""
        gm, pairs = self.coal_geometry()
        index = {p: k for k, p in enumerate(pairs)}
        return gm, [self.pair_names[index[(cp.first, cp.second)]] for cp in gm.collisionPairs]

    def coal_geometry(self) -> tuple[pin.GeometryModel, list[tuple[int, int]]]:
        """The ``GeometryModel`` and, per checked pair (``pair_names`` order), its two geometry
        object indices (smaller first, as in ``gm.collisionPairs``)."""
        return build_geometry_model(self.geometry, self.obstacles, self._T_base_world,
                                    self._obs_pairs, self._self_pairs)  # fmt: skip

    def closest_pairs(
        self, q: np.ndarray, limit: int = 20
    ) -> list[tuple[tuple[str, str], float, np.ndarray, np.ndarray]]:
        """Per pair of names (closest shape pair of each), closest first, at most ``limit``:
        ``(links, distance [m], point on the first, point on the second)``, points in the base frame
        (coal via pinocchio's ``computeDistances``)."""
        gm, pairs = self.coal_geometry()
        return closest_pairs(
            self.robot.model, gm, pairs, self.pair_names, self._T_base_world, q, limit
        )
