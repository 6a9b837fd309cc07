"""The fast per-configuration clearance of a collision-free motion search: coal through pinocchio.

A sampling planner asks one question many thousand times: how far is every checked pair from its
threshold at this configuration? ``CollisionChecker.distances`` (the numpy engine) answers it for
thousands of configurations at once, but one configuration at a time costs milliseconds; coal, on
the checker's own ``GeometryModel`` (``CollisionChecker.geometry_model``), answers it in about
0.1 ms. Reading a thousand coal results back into Python costs more than computing them, so the
checker's pairs are split into groups and coal reports only each group's smallest distance (the
index ``pin.computeDistances`` returns): one group per robot link and kind (that link against the
obstacles; that link against other links, a pair belonging to the group of its first link).

``GroupedClearance`` is a ``core.clearance.Clearance`` whose "pairs" are these groups: a group's
distance is the minimum over its pairs, its threshold their common threshold (``clearance`` for
obstacles, 0 for self pairs) and its ``motion_weights`` row the largest of its pairs' rows, so the
Lipschitz bound of the Protocol holds for the group (a minimum of functions that each change by at
most ``w_p . |dq|`` changes by at most ``max_p w_p . |dq|``). ``closest_pair`` names the real pair
behind a group's distance; ``check_path`` is the checker's own continuous check.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pinocchio as pin

from robots.collision import CollisionChecker, PathCheck
from robots.collision.dampers import point_jacobian


class GroupedClearance:
    """Group minima of a ``CollisionChecker``'s pair distances, computed by coal.

    Args:
        checker: The request's checker (robot, obstacles, clearance, allowed pairs).

    Attributes:
        pair_names: ``(link, "obstacles")`` or ``(link, "links")`` per group.
        threshold: ``(G,)`` [m] distance below which a group is in contact.
        motion_weights: ``(G, dof)``: a group's distance changes by at most ``row @ |dq|`` [m].
        evaluations: Configurations evaluated so far.
    """

    def __init__(self, checker: CollisionChecker) -> None:
        self.checker = checker
        robot = checker.robot
        self._model = robot.model
        self._gm, names = checker.geometry_model()
        links = set(robot.frame_names())
        group_of: dict[tuple[str, str], int] = {}
        self._pair_group = np.empty(len(names), dtype=int)
        for k, (a, b) in enumerate(names):
            key = (a, "links" if b in links else "obstacles")
            self._pair_group[k] = group_of.setdefault(key, len(group_of))
        self._names = list(names)
        self.pair_names: list[tuple[str, str]] = list(group_of)
        G, dof = len(group_of), robot.dof
        # a group's threshold and weights: the largest of its pairs' (several shapes per link)
        kind = {n: "links" for n in links}
        of_pair = np.array(
            [group_of[(a, kind.get(b, "obstacles"))] for a, b in checker.pair_names], dtype=int
        )
        self.threshold = np.zeros(G)
        self.motion_weights = np.zeros((G, dof))
        np.maximum.at(self.threshold, of_pair, np.asarray(checker.threshold, dtype=float))
        np.maximum.at(self.motion_weights, of_pair, np.asarray(checker.motion_weights, dtype=float))
        self._members = [np.flatnonzero(self._pair_group == g) for g in range(G)]
        self._build_groups()
        self._local = threading.local()
        self.evaluations = 0

    # one workspace per thread: pinocchio data is not shared between threads --------------------
    def _workspace(self) -> tuple[Any, list[tuple[Any, Any]]]:
        """``pin.Data`` and, per group, a ``GeometryModel`` holding only the group's pairs (and the
        objects they use) with its ``GeometryData``: coal then loops over that group alone."""
        ws = getattr(self._local, "ws", None)
        if ws is None:
            ws = (pin.Data(self._model), [(gm, pin.GeometryData(gm)) for gm in self._group_models])
            self._local.ws = ws
        return ws

    def _broadphase(self, margin: float) -> Any:
        """coal's naive broad phase over every pair (bounding boxes first, then the pairs whose
        boxes, grown by the pair's security margin, overlap), the margins set to each pair's
        threshold plus ``margin``; one per thread and margin."""
        cache = getattr(self._local, "broadphase", None)
        if cache is None or cache[0] != margin:
            gd = pin.GeometryData(self._gm)
            thr = self.threshold[self._pair_group] + margin
            for k, t in enumerate(thr):
                gd.collisionRequests[k].security_margin = float(t)
            manager = pin.BroadPhaseManager_NaiveCollisionManager(self._model, self._gm, gd)
            cache = (margin, manager, gd)
            self._local.broadphase = cache
        return cache[1]

    def collides(self, q: np.ndarray, margin: float) -> bool:
        """``core.motion.clearance.GroupClearance.collides``: ``pin.computeCollisions`` through
        the broad phase, stopping at the first pair closer than its threshold plus ``margin``."""
        data, _ = self._workspace()
        self.evaluations += 1
        manager = self._broadphase(float(margin))
        return bool(pin.computeCollisions(self._model, data, manager, np.asarray(q, float), True))

    def _build_groups(self) -> None:
        objects = list(self._gm.geometryObjects)
        pairs = [(cp.first, cp.second) for cp in self._gm.collisionPairs]
        self._group_models, self._group_pairs = [], []
        for members in self._members:
            gm = pin.GeometryModel()
            new: dict[int, int] = {}
            for k in members.tolist():
                first, second = pairs[k]
                for i in (first, second):
                    if i not in new:
                        new[i] = gm.addGeometryObject(objects[i])
                gm.addCollisionPair(pin.CollisionPair(new[first], new[second]))
            self._group_models.append(gm)
            self._group_pairs.append(np.asarray(members, dtype=int))

    def _group_minima(
        self, q: np.ndarray, groups: np.ndarray | None = None
    ) -> tuple[np.ndarray, list[int], list[Any]]:
        """Distances [m] of ``groups`` (default all, in order), the coal pair index of each
        group's minimum, and the group data."""
        data, groups_ws = self._workspace()
        pin.forwardKinematics(self._model, data, q)
        chosen = range(len(groups_ws)) if groups is None else groups
        out = np.empty(len(chosen))
        index = []
        for i, g in enumerate(chosen):
            gm, gd = groups_ws[g]
            pin.updateGeometryPlacements(self._model, data, gm, gd)
            k = int(pin.computeDistances(gm, gd))
            index.append(k)
            out[i] = gd.distanceResults[k].min_distance
        self.evaluations += 1
        return out, index, groups_ws

    def pair_distances(self, q: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        """``core.motion.clearance.GroupClearance.pair_distances``: the distances [m] of groups
        ``pairs`` at ``q`` ``(dof,)``."""
        return self._group_minima(np.asarray(q, dtype=float), np.asarray(pairs, dtype=int))[0]

    # core.clearance.Clearance ---------------------------------------------------------------------
    def distances(self, qs: np.ndarray) -> np.ndarray:
        """Smallest signed distance ``(N, G)`` [m] of each group at each row of ``qs`` ``(N, dof)``."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        return np.array([self._group_minima(q)[0] for q in qs]).reshape(len(qs), len(self._members))

    def min_distances(self, qs: np.ndarray) -> np.ndarray:
        """Smallest distance ``(N,)`` [m] over every pair at each row of ``qs`` (coal; the same
        value as ``CollisionChecker.min_distances`` to coal's tolerance where no pair touches).

        Rows in sequence (a motion's points) share their work: a group's distance at a row is at
        least its distance (or bound) at the row before minus its motion bound over the step, so
        after the group nearest by that bound is evaluated only the groups whose bound falls below
        its distance are (exact: every other group is at least that far)."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        G = len(self._members)
        out = np.full(len(qs), np.inf)
        if G == 0 or len(qs) == 0:
            return out
        value = self._group_minima(qs[0])[0]
        out[0] = value.min()
        for n in range(1, len(qs)):
            value = value - self.motion_weights @ np.abs(qs[n] - qs[n - 1])
            first = int(np.argmin(value))
            value[first] = self._group_minima(qs[n], np.array([first]))[0][0]
            rest = np.flatnonzero(value < value[first])
            if len(rest):
                value[rest] = self._group_minima(qs[n], rest)[0]
            out[n] = value.min()
        return out

    def check_path(self, times: np.ndarray, qs: np.ndarray) -> PathCheck:
        """The checker's continuous check (every pair, names of the real pairs)."""
        return self.checker.check_path(times, qs)

    def close_pairs(
        self, q: np.ndarray, d_influence: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The closest pair of every group closer than ``d_influence`` [m] at ``q``: group indices,
        distances, unit normals (towards the first body) and point Jacobians ``(m, 3, dof)``, in
        the base frame (the inputs of ``core.clearance.velocity_damper_rows``)."""
        q = np.asarray(q, dtype=float)
        d, index, groups_ws = self._group_minima(q)
        data, _ = self._workspace()
        model = self._model
        pin.computeJointJacobians(model, data, q)
        R = np.asarray(self.checker.robot.chain.T_base_world)[:3, :3]
        rows, dist, normals, jacs = [], [], [], []
        for g in np.flatnonzero(d < d_influence):
            gm, gd = groups_ws[g]
            res = gd.distanceResults[index[g]]
            cp = gm.collisionPairs[index[g]]
            p1, p2 = np.asarray(res.getNearestPoint1()), np.asarray(res.getNearestPoint2())
            gap = p1 - p2
            n = gap / np.linalg.norm(gap) if d[g] > 1e-9 else -np.asarray(res.normal)
            J = point_jacobian(model, data, gm, cp.first, p1)
            J -= point_jacobian(model, data, gm, cp.second, p2)
            rows.append(g)
            dist.append(d[g])
            normals.append(R @ n)
            jacs.append(R @ J)
        m = len(rows)
        return (
            np.array(rows, dtype=int),
            np.array(dist),
            np.reshape(normals, (m, 3)),
            np.reshape(jacs, (m, 3, model.nv)),
        )

    # naming ------------------------------------------------------------------------------------
    def closest_pair(self, q: np.ndarray) -> tuple[tuple[str, str], float, float]:
        """The real pair with the smallest margin over its threshold at ``q``: ``(names, distance
        [m], threshold [m])``."""
        d, index, _ = self._group_minima(np.asarray(q, dtype=float))
        g = int(np.argmin(d - self.threshold))
        name = self._names[int(self._group_pairs[g][index[g]])]
        return name, float(d[g]), float(self.threshold[g])
