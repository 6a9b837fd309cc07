"""Collision geometry of a robot in a work cell: distances and a continuous check of joint motions.

Robot geometry is a set of capsules (segment ``a``-``b`` plus ``radius``; a sphere has ``a == b``) fixed
to the model's joints: the shipped robots' capsules come from ``robots.geometry``; an inline URDF's
``<collision>`` spheres are used as they are and its boxes and cylinders are enclosed in capsules
(conservative: the reported distance is never larger than the true one); mesh-only links are listed in
``unchecked_links`` (a warning). Obstacles are primitives (``Obstacle``): box, sphere, cylinder,
capsule, halfspace, in the robot's base frame.

Two engines compute the same distances:

* numpy closed forms (``robots.geometry.distance``), vectorized over (configuration, pair) entries
  (``distances``): segment-segment (capsule-capsule, capsule-sphere), endpoint signed distances
  (capsule-halfspace), and for boxes and cylinders the minimum over the segment of the shape's signed
  distance function. This is what the continuous check runs on thousands of configurations.
* pinocchio's ``GeometryModel`` with coal (``closest_pairs``): one configuration, with witness points,
  for ``POST /distance``; tests check the two engines agree.

Continuous check (``CollisionChecker.check_path``): joints move linearly between consecutive returned
points. Any point of capsule ``g`` moves by at most ``sum_k L_kg |dq_k|`` over a joint step ``dq``, where
``L_kg`` bounds the distance of the capsule from joint ``k``'s axis over all configurations (link
lengths from joint ``k`` to the capsule plus its extent; 1 for prismatic joints). A pair's distance is
1-Lipschitz in that motion, so over an interval with end distances ``d_i``, ``d_j`` and motion bound
``B`` (summed over the interval's joint travel) the distance never falls below ``(d_i + d_j - B) / 2``.
Branch and bound on (interval, pair) from every ``KEY_STEP``-th point: intervals are split while that
bound is below the threshold (``clearance`` for obstacles, 0 for self pairs) or below the smallest
distance found so far, single segments at their joint midpoint. A segment whose bound falls below
``MOTION_TOLERANCE`` with both ends clear counts as clear. The first contact is the earliest
configuration found below the threshold (located to within that tolerance).

The base link stands on its mount: geometry fixed to the model's root is checked for self-collision
only, never against obstacles.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from core.errors import TooLarge
from robots.geometry import ROBOT_GEOMETRY, Capsule
from robots.geometry.distance import sdf_box, sdf_cylinder, segment_sdf_min, segment_segment
from robots.geometry.joints import JointPlacements
from robots.geometry.urdf import capsules_from_urdf
from robots.model import Robot

MOTION_TOLERANCE = 1e-7
"""[m] A segment whose motion bound is below this and whose ends are clear counts as clear."""
MAX_LEVELS = 60
"""Most halvings of one returned segment (2^-60 of its motion: far below ``MOTION_TOLERANCE``)."""
MAX_CAPSULES = 128
"""Most collision primitives of an inline URDF (its self pairs grow with the square: building the
allowed pairs took 0.4 s for 92 primitives, 1.0 s for 184, 2.3 s for 276, once per robot). 128 takes
real robots with two arms and hands (franka_description's dual Panda has 89; 64 refused it)."""
CHUNK_ENTRIES = 200_000
"""Most pair distances computed in one vectorized call (bounds the memory of a check)."""
MAX_KEY_ENTRIES = 5_000_000
"""Most (key point, pair) entries of one continuous check: points x pairs / KEY_STEP (TooLarge)."""
KEY_STEP = 16
"""The continuous check first evaluates every KEY_STEP-th returned point, then refines."""
SAMPLES_FOR_ALLOWED = 4000
"""Random configurations that decide which self pairs never touch (``allowed_self_collisions``)."""
MAX_ALLOWED_WORK = 2_000_000
"""Most pair distances spent on that decision for one robot (inline URDFs with many primitives)."""
SHAPES = ("box", "sphere", "cylinder", "capsule", "halfspace")


@dataclass(frozen=True)
class Obstacle:
    """One obstacle, in the robot's base frame.

    Attributes:
        name: Unique among obstacles and different from every link name.
        shape: ``box`` (``size`` = full edge lengths [m]), ``sphere`` (``radius``), ``cylinder`` and
            ``capsule`` (``radius``, ``length`` along the local z axis, centred; a capsule's length is
            the distance between its hemisphere centres), ``halfspace`` (solid where
            ``normal . x <= offset``; no pose).
        T_base_obstacle: ``(4, 4)`` pose [m] (identity for a halfspace).
    """

    name: str
    shape: str
    size: tuple[float, ...] = ()
    radius: float = 0.0
    length: float = 0.0
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    T_base_obstacle: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass(frozen=True)
class Contact:
    """The first configuration found closer than the threshold.

    Attributes:
        time: [s] from the start of the motion.
        links: ``(robot_link, obstacle_name_or_link)``.
        distance: [m] signed (negative: penetration).
        index: Index of the returned segment (0-based) that holds the contact.
    """

    time: float
    links: tuple[str, str]
    distance: float
    index: int


@dataclass(frozen=True)
class PathCheck:
    """Result of a continuous check.

    Attributes:
        contact: First contact, or None when the motion is clear.
        min_clearance: [m] smallest distance over every checked pair at the returned points (exact:
            branch and bound) and at the split points evaluated; inf when no pair is checked.
        closest: ``(links, time)`` of that smallest distance.
        evaluations: Pair distances computed.
    """

    contact: Contact | None
    min_clearance: float
    closest: tuple[tuple[str, str], float] | None
    evaluations: int


@dataclass(frozen=True)
class RobotCollision:
    """A robot's capsules, attached to its pinocchio joints (built once per robot).

    Attributes:
        links: ``(G,)`` link name of each capsule.
        joints: ``(G,)`` pinocchio joint index carrying each capsule (0: the fixed root).
        a, b: ``(G, 3)`` segment ends in the joint frame [m].
        radius: ``(G,)`` [m].
        unchecked_links: Links whose collision geometry is mesh-only (not checked).
    """

    links: tuple[str, ...]
    joints: np.ndarray
    a: np.ndarray
    b: np.ndarray
    radius: np.ndarray
    unchecked_links: tuple[str, ...] = ()


# --- building the robot's capsules ---------------------------------------------------------------
def _link_frame_id(model: pin.Model, link: str) -> int:
    """The frame of link ``link``, looked up by kind: a joint may share a link's name (Baxter's
    ``right_hand``), and pinocchio's untyped look-up then fails ("Several frames match")."""
    return model.getFrameId(link, pin.FrameType.BODY)


def _attach(model: pin.Model, capsules: Sequence[Capsule]) -> RobotCollision:
    """Capsules given in link frames -> capsules in their parent joint frames."""
    links, joints, a, b, r = [], [], [], [], []
    for c in capsules:
        if not model.existFrame(c.link, pin.FrameType.BODY):
            continue  # a link the reduced model does not hold (not on the base -> tip chain)
        frame = model.frames[_link_frame_id(model, c.link)]
        M = frame.placement
        links.append(c.link)
        joints.append(frame.parentJoint)
        a.append(M.act(np.array(c.a, dtype=float)))
        b.append(M.act(np.array(c.b, dtype=float)))
        r.append(c.radius)
    return RobotCollision(
        tuple(links),
        np.array(joints, dtype=int),
        np.reshape(a, (-1, 3)),
        np.reshape(b, (-1, 3)),
        np.array(r, dtype=float),
    )


def robot_collision(robot: Robot, urdf: str | None = None) -> RobotCollision:
    """The capsules of a shipped robot (``robots.geometry``) or of an inline URDF's primitives."""
    if urdf is None:
        geometry = ROBOT_GEOMETRY.get(robot.name)
        return _attach(robot.model, geometry.capsules if geometry else ())
    capsules, mesh_only = capsules_from_urdf(urdf)
    rc = _attach(robot.model, capsules)
    if len(rc.links) > MAX_CAPSULES:
        raise TooLarge(
            f"the URDF has {len(rc.links)} collision primitives on the robot; at most "
            f"{MAX_CAPSULES} are checked",
            field=("robot", "urdf"),
            extra={"limit_primitives": MAX_CAPSULES},
        )
    held = [m for m in mesh_only if robot.model.existFrame(m, pin.FrameType.BODY)]
    return RobotCollision(rc.links, rc.joints, rc.a, rc.b, rc.radius, tuple(held))


class CollisionChecker:
    """Distances between a robot's capsules, obstacles and its own links, for many configurations.

    Args:
        robot: The robot (its pinocchio model carries the joints).
        geometry: Its capsules (``robot_collision``).
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
        # obstacle pairs: every capsule not on the root against every obstacle
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
        self._weights = self._motion_weights()
        self._prepare_entries()
        self._coal: tuple[Any, ...] | None = None  # damper_inputs' workspace, built on first use

    @property
    def n_pairs(self) -> int:
        return len(self.pair_names)

    @property
    def motion_weights(self) -> np.ndarray:
        """``core.clearance.Clearance.motion_weights``: ``(P, dof)``, a pair's distance changes by
        at most ``motion_weights @ |dq|`` [m] over a linear joint step ``dq``."""
        return self._weights

    # motion bound ------------------------------------------------------------------------------
    def _motion_weights(self) -> np.ndarray:
        """``(P, nq)``: a pair's distance changes by at most ``weights @ |dq|`` over a linear step."""
        jt = self._joints
        J = len(jt.parents)
        link_len = np.linalg.norm(jt.p, axis=1)
        lim = np.abs(self.robot.position_limits).max(axis=1)
        g = self.geometry
        # lever[k, i]: bound on the distance from joint k+1's origin to any point of capsule i
        lever = np.zeros((J, len(g.links)))
        for i in range(len(g.links)):
            extent = max(np.linalg.norm(g.a[i]), np.linalg.norm(g.b[i])) + g.radius[i]
            j = int(g.joints[i])
            reach = extent
            while j != 0:  # walk up: joint j's own origin is where it sits
                k = j - 1
                lever[k, i] = 1.0 if not jt.revolute[k] else reach
                reach += link_len[k] + (0.0 if jt.revolute[k] else lim[jt.q_index[k]])
                j = int(jt.parents[k])
        nq = self.robot.dof
        W = np.zeros((self.n_pairs, nq))
        for p, (i, _) in enumerate(self._obs_pairs):
            np.add.at(W[p], jt.q_index, lever[:, i])
        off = len(self._obs_pairs)
        for p, (i, j) in enumerate(self._self_pairs):
            # joints shared by both capsules move them rigidly together: only the others count
            anc_i, anc_j = self._ancestors(int(g.joints[i])), self._ancestors(int(g.joints[j]))
            for k in anc_i ^ anc_j:
                cap = i if k in anc_i else j
                W[off + p, jt.q_index[k - 1]] += lever[k - 1, cap]
        return W

    def _ancestors(self, j: int) -> set[int]:
        out = set()
        while j != 0:
            out.add(j)
            j = int(self._joints.parents[j - 1])
        return out

    # obstacles ---------------------------------------------------------------------------------
    def _capsules_world(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Capsule ends in the base frame: ``(N, G, 3)`` twice."""
        Rw, pw = self._joints.placements(qs)
        g = self.geometry
        n = qs.shape[0]
        A = np.empty((n, len(g.links), 3))
        B = np.empty((n, len(g.links), 3))
        T = self._T_base_world
        moved = not np.array_equal(T, np.eye(4))
        for i, j in enumerate(g.joints):
            flat = Rw[j].reshape(3 * n, 3)
            A[:, i] = (flat @ g.a[i]).reshape(n, 3) + pw[j]
            B[:, i] = (flat @ g.b[i]).reshape(n, 3) + pw[j]
        if moved:
            A = A @ T[:3, :3].T + T[:3, 3]
            B = B @ T[:3, :3].T + T[:3, 3]
        return A, B

    def distances(self, qs: np.ndarray) -> np.ndarray:
        """Signed distances ``(N, P)`` [m] of every checked pair (``pair_names`` order) for each row of
        ``qs`` ``(N, dof)``; negative: penetration. Exact (no bounds), in chunks of bounded memory."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        n, P = qs.shape[0], self.n_pairs
        out = np.empty((n, P))
        rows = max(1, CHUNK_ENTRIES // max(P, 1))
        for k in range(0, n, rows):
            A, B = self._capsules_world(qs[k : k + rows])
            m = len(A)
            r, p = np.repeat(np.arange(m), P), np.tile(np.arange(P), m)
            out[k : k + m] = self._entries(A, B, r, p).reshape(m, P)
        return out

    def min_distances(self, qs: np.ndarray) -> np.ndarray:
        """Smallest signed distance ``(N,)`` [m] over every checked pair for each row of ``qs``
        ``(N, dof)``: ``distances(qs).min(axis=1)``, exact, but box and cylinder entries whose
        bounding-sphere lower bound is not below the row's smallest exact distance are skipped."""
        qs = np.atleast_2d(np.asarray(qs, dtype=float))
        n, P = qs.shape[0], self.n_pairs
        out = np.full(n, math.inf)
        boxy_obs = np.isin(self._kind, (SHAPES.index("box"), SHAPES.index("cylinder")))
        n_obs = len(self._obs_pairs)
        boxy = np.zeros(P, dtype=bool)
        boxy[:n_obs] = boxy_obs[self._ok] if n_obs else False
        rows = max(1, CHUNK_ENTRIES // max(P, 1))
        for k in range(0, n, rows):
            A, B = self._capsules_world(qs[k : k + rows])
            m = len(A)
            r, p = np.repeat(np.arange(m), P), np.tile(np.arange(P), m)
            d = self._entries(A, B, r, p, -math.inf)  # box, cylinder: exact or a lower bound
            best = np.full(m, math.inf)
            np.minimum.at(best, r[~boxy[p]], d[~boxy[p]])
            todo = np.flatnonzero(boxy[p])
            # the box entry with the smallest bound of each row first, then whatever may still win
            for stage in range(2):
                todo = todo[d[todo] < best[r[todo]]]
                if stage == 0 and len(todo):
                    order = todo[np.lexsort((d[todo], r[todo]))]
                    pick = order[np.r_[True, r[order][1:] != r[order][:-1]]]
                else:
                    pick = todo
                if len(pick):
                    d[pick] = self._entries(A, B, r[pick], p[pick])
                    np.minimum.at(best, r[pick], d[pick])
                    todo = np.setdiff1d(todo, pick)
            out[k : k + m] = best
        return out

    # per-entry distances ---------------------------------------------------------------------
    def _prepare_entries(self) -> None:
        """Per-pair and per-obstacle arrays for ``_entries``."""
        self._ci = np.array([i for i, _ in self._obs_pairs], dtype=int)
        self._ok = np.array([k for _, k in self._obs_pairs], dtype=int)
        self._si = np.array([i for i, _ in self._self_pairs], dtype=int)
        self._sj = np.array([j for _, j in self._self_pairs], dtype=int)
        obs = self.obstacles
        self._obs_T_inv = np.array([np.linalg.inv(o.T_base_obstacle) for o in obs]).reshape(
            -1, 4, 4
        )
        self._kind = np.array([SHAPES.index(o.shape) for o in obs], dtype=int)
        self._radius = np.array([o.radius for o in obs])
        self._half_length = np.array([o.length / 2 if o.shape == "capsule" else 0.0 for o in obs])
        self._cyl = np.array([[o.radius, o.length / 2] for o in obs]).reshape(-1, 2)
        self._half = np.array([np.resize(np.array(o.size, float), 3) / 2 for o in obs]).reshape(
            -1, 3
        )
        self._normal = np.array([o.normal for o in obs], dtype=float).reshape(-1, 3)
        self._bound = np.array(  # bounding-sphere radius about the centre (box, cylinder)
            [np.linalg.norm(self._half[k]) if o.shape == "box" else np.hypot(*self._cyl[k])
             for k, o in enumerate(obs)]
        )  # fmt: skip
        self._offset = np.array([o.offset for o in obs])

    def _entries(
        self,
        A: np.ndarray,
        B: np.ndarray,
        r: np.ndarray,
        p: np.ndarray,
        floor: float | None = None,
    ) -> np.ndarray:
        """Distances [m] of pairs ``p`` (K,) at configurations ``r`` (K,), rows of the capsule ends
        ``A``, ``B`` (n, G, 3): the same closed forms as ``distances``, one vector per entry list.

        With a ``floor`` [m] (the smallest distance known), box and cylinder entries whose lower
        bound (distance to the obstacle's bounding sphere) is at least ``max(threshold, min(floor,
        the smallest other distance of the call))`` keep that bound: they can be neither a contact
        nor the smallest distance, and a lower bound keeps every interval test of the continuous
        check valid. Without one, every entry is exact."""
        out = np.empty(len(r))
        rad = self.geometry.radius
        n_obs = len(self._obs_pairs)
        is_obs = p < n_obs
        if (~is_obs).any():
            e = np.flatnonzero(~is_obs)
            i, j = self._si[p[e] - n_obs], self._sj[p[e] - n_obs]
            d, _, _ = segment_segment(A[r[e], i], B[r[e], i], A[r[e], j], B[r[e], j])
            out[e] = d - rad[i] - rad[j]
        if not is_obs.any():
            return out
        e = np.flatnonzero(is_obs)
        ci, ok = self._ci[p[e]], self._ok[p[e]]
        a, b = A[r[e], ci], B[r[e], ci]
        kind = self._kind[ok]
        hs = kind == SHAPES.index("halfspace")
        if hs.any():
            n_, off = self._normal[ok[hs]], self._offset[ok[hs]]
            low = np.minimum((a[hs] * n_).sum(axis=1), (b[hs] * n_).sum(axis=1))
            out[e[hs]] = low - off - rad[ci[hs]]
        rest = np.flatnonzero(~hs)
        if len(rest) == 0:
            return out
        Ti = self._obs_T_inv[ok[rest]]
        al = np.einsum("kij,kj->ki", Ti[:, :3, :3], a[rest]) + Ti[:, :3, 3]
        bl = np.einsum("kij,kj->ki", Ti[:, :3, :3], b[rest]) + Ti[:, :3, 3]
        k_rest, o_rest, c_rest = kind[rest], ok[rest], ci[rest]
        for shape in ("sphere", "capsule", "box", "cylinder"):
            m = k_rest == SHAPES.index(shape)
            if not m.any():
                continue
            if shape in ("box", "cylinder") and floor is not None:
                done = np.ones(len(out), dtype=bool)
                boxy = np.isin(k_rest, (SHAPES.index("box"), SHAPES.index("cylinder")))
                done[e[rest[boxy]]] = False  # every other entry is filled by now
                level = min(floor, float(out[done].min()) if done.any() else math.inf)
                level = max(level, float(self.threshold.max()))
                o = o_rest[m]
                zero = np.zeros((int(m.sum()), 3))
                lb, _, _ = segment_segment(al[m], bl[m], zero, zero)
                lb = lb - self._bound[o] - rad[c_rest[m]]
                far = lb >= level
                out[e[rest[np.flatnonzero(m)[far]]]] = lb[far]
                m = m.copy()
                m[np.flatnonzero(m)[far]] = False
                if not m.any():
                    continue
            o = o_rest[m]
            if shape in ("sphere", "capsule"):
                h = np.zeros((len(o), 3))
                h[:, 2] = self._half_length[o]
                d, _, _ = segment_segment(al[m], bl[m], -h, h)
                d = d - self._radius[o]
            elif shape == "box":
                half = self._half[o]
                d = segment_sdf_min(al[m], bl[m], lambda x, half=half: sdf_box(x, half))
            else:
                cyl = self._cyl[o]
                d = segment_sdf_min(
                    al[m], bl[m], lambda x, cyl=cyl: sdf_cylinder(x, cyl[:, 0], cyl[:, 1])
                )
            out[e[rest[m]]] = d - rad[c_rest[m]]
        return out

    # continuous check --------------------------------------------------------------------------
    def check_path(self, times: np.ndarray, qs: np.ndarray) -> PathCheck:
        """Continuous check of the motion through ``qs`` ``(N, dof)`` at ``times`` ``(N,)`` [s],
        joints moving linearly between consecutive rows.

        Branch and bound on (interval of returned points, pair): every ``KEY_STEP``-th point is
        evaluated for every pair; over an interval the distance of a pair cannot fall below
        ``(d_i + d_j - B_ij) / 2``, with ``B_ij`` the pair's motion bound applied to the joint
        travel summed over the interval's segments. An interval is split (at its middle returned
        point) while that bound is below the threshold (contact) or below the smallest distance
        found so far (so ``min_clearance`` is the exact minimum over the returned points). A single
        segment still below the threshold is split at joint midpoints until it is clear or the
        contact is located."""
        times = np.asarray(times, dtype=float)
        qs = np.asarray(qs, dtype=float)
        n, P = len(qs), self.n_pairs
        if P == 0:
            return PathCheck(None, math.inf, None, 0)
        thr, W = self.threshold, self._weights
        keys = np.unique(np.r_[np.arange(0, n, KEY_STEP), n - 1])
        if len(keys) * P > MAX_KEY_ENTRIES:
            raise TooLarge(
                f"checking {n} points against {P} pairs is too large (at most "
                f"{MAX_KEY_ENTRIES * KEY_STEP} points x pairs); use fewer points or obstacles",
                field=("environment",),
                extra={"limit_points_x_pairs": MAX_KEY_ENTRIES * KEY_STEP},
            )
        C = np.vstack([np.zeros(qs.shape[1]), np.cumsum(np.abs(np.diff(qs, axis=0)), axis=0)])
        state = {"t": math.inf, "p": -1, "d": 0.0, "seg": -1, "min": math.inf, "min_t": 0.0,
                 "min_p": -1, "count": 0}  # fmt: skip

        def note(t: np.ndarray, seg: np.ndarray, pp: np.ndarray, d: np.ndarray) -> None:
            state["count"] += len(d)
            if len(d) == 0:
                return
            k = int(np.argmin(d))
            if d[k] < state["min"]:
                state.update(min=float(d[k]), min_t=float(t[k]), min_p=int(pp[k]))
            bad = np.flatnonzero(d < thr[pp])
            if len(bad):
                b = bad[np.lexsort((d[bad] - thr[pp[bad]], t[bad]))[0]]
                if t[b] < state["t"]:
                    state.update(t=float(t[b]), p=int(pp[b]), d=float(d[b]), seg=int(seg[b]))

        def evaluate(rows: np.ndarray, pp: np.ndarray) -> np.ndarray:
            """Distances of pairs ``pp`` at returned points ``rows`` (chunked: bounded memory)."""
            out = np.empty(len(rows))
            for k in range(0, len(rows), CHUNK_ENTRIES):
                r_, p_ = rows[k : k + CHUNK_ENTRIES], pp[k : k + CHUNK_ENTRIES]
                used = np.unique(r_)
                A, B = self._capsules_world(qs[used])
                d = self._entries(A, B, np.searchsorted(used, r_), p_, state["min"])
                out[k : k + len(d)] = d
                note(times[r_], np.maximum(r_ - 1, 0), p_, d)
            return out

        DK = evaluate(np.repeat(keys, P), np.tile(np.arange(P), len(keys))).reshape(len(keys), P)
        ii, jj = np.repeat(keys[:-1], P), np.repeat(keys[1:], P)
        pp = np.tile(np.arange(P), len(keys) - 1)
        Di, Dj = DK[:-1].reshape(-1), DK[1:].reshape(-1)
        segments: list[tuple[np.ndarray, ...]] = []
        while len(ii):
            lower = (Di + Dj - np.einsum("kd,kd->k", C[jj] - C[ii], W[pp])) / 2
            need_c = (lower < thr[pp]) & (Di >= thr[pp]) & (times[ii] < state["t"])
            need = need_c | (lower < state["min"])
            multi = jj - ii > 1
            one = need_c & ~multi
            segments.append((ii[one], pp[one], Di[one], Dj[one]))
            split = need & multi
            ii, jj, pp, Di, Dj = ii[split], jj[split], pp[split], Di[split], Dj[split]
            mm = (ii + jj) // 2
            Dm = evaluate(mm, pp)
            ii, jj, pp = np.r_[ii, mm], np.r_[mm, jj], np.r_[pp, pp]
            Di, Dj = np.r_[Di, Dm], np.r_[Dm, Dj]
        seg, pp, Da, Db = (np.concatenate([x[k] for x in segments]) for k in range(4))
        self._refine_segments(times, qs, seg.astype(int), pp.astype(int), Da, Db, note, state)
        contact = None
        if state["p"] >= 0:
            contact = Contact(state["t"], self.pair_names[state["p"]], state["d"], state["seg"])
        closest = (self.pair_names[state["min_p"]], state["min_t"])
        return PathCheck(contact, state["min"], closest, state["count"])

    def _refine_segments(
        self,
        times: np.ndarray,
        qs: np.ndarray,
        seg: np.ndarray,
        pp: np.ndarray,
        Da: np.ndarray,
        Db: np.ndarray,
        note: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], None],
        state: dict[str, Any],
    ) -> None:
        """Split single segments (``seg``, pair ``pp``) at joint midpoints until each is clear or
        its contact is located (``MOTION_TOLERANCE``)."""
        ta, tb, qa, qb = times[seg], times[seg + 1], qs[seg], qs[seg + 1]
        thr, W = self.threshold, self._weights
        for _ in range(MAX_LEVELS):
            keep = ta < state["t"]
            ta, tb, qa, qb, Da, Db, seg, pp = (x[keep] for x in (ta, tb, qa, qb, Da, Db, seg, pp))
            if len(ta) == 0:
                return
            bound = np.einsum("kd,kd->k", np.abs(qb - qa), W[pp])
            lower = (Da + Db - bound) / 2
            need = (lower < thr[pp]) & (Da >= thr[pp])
            tiny = bound < MOTION_TOLERANCE
            hit = np.flatnonzero(need & tiny & (Db < thr[pp]))  # contact at tb, within tolerance
            if len(hit):
                k = hit[np.argmin(tb[hit])]
                if tb[k] < state["t"]:
                    state.update(t=float(tb[k]), p=int(pp[k]), d=float(Db[k]), seg=int(seg[k]))
            split = need & ~tiny
            ta, tb, qa, qb, Da, Db, seg, pp = (x[split] for x in (ta, tb, qa, qb, Da, Db, seg, pp))
            tm, qm = (ta + tb) / 2, (qa + qb) / 2
            Dm = np.empty(len(tm))
            step = max(1, CHUNK_ENTRIES // max(len(self.geometry.links), 1))
            for k in range(0, len(tm), step):  # chunks: bounded memory
                Am, Bm = self._capsules_world(qm[k : k + step])
                idx = np.arange(len(Am))
                Dm[k : k + step] = self._entries(Am, Bm, idx, pp[k : k + step], state["min"])
            note(tm, seg, pp, Dm)
            ta, tb = np.r_[ta, tm], np.r_[tm, tb]
            qa, qb = np.r_[qa, qm], np.r_[qm, qb]
            Da, Db = np.r_[Da, Dm], np.r_[Dm, Db]
            seg, pp = np.r_[seg, seg], np.r_[pp, pp]

    def close_pairs(
        self, q: np.ndarray, d_influence: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``core.clearance.Clearance.close_pairs``: ``damper_inputs`` as a tuple."""
        d = damper_inputs(self, q, d_influence)
        return d.pairs, d.distances, d.normals, d.point_jacobians

    # one configuration, with coal ----------------------------------------------------------------
    def geometry_model(self) -> tuple[pin.GeometryModel, list[tuple[str, str]]]:
        """A pinocchio ``GeometryModel`` of the capsules and obstacles (coal shapes) with one collision
        pair per checked pair, and the names of each of ``gm.collisionPairs`` in that order."""
        gm, names, pairs = self._geometry_model()
        index = {p: k for k, p in enumerate(pairs)}
        return gm, [names[index[(cp.first, cp.second)]] for cp in gm.collisionPairs]

    def _geometry_model(
        self,
    ) -> tuple[pin.GeometryModel, list[tuple[str, str]], list[tuple[int, int]]]:
        gm = pin.GeometryModel()
        g = self.geometry
        T_world_base = np.linalg.inv(self._T_base_world)
        ids = []
        for i in range(len(g.links)):
            a, b = g.a[i], g.b[i]
            length = float(np.linalg.norm(b - a))
            z = (b - a) / length if length > 1e-12 else np.array([0.0, 0.0, 1.0])
            R = _frame_with_z(z)
            M = pin.SE3(R, (a + b) / 2)
            shape = (
                coal.Capsule(float(g.radius[i]), length)
                if length > 1e-12
                else coal.Sphere(float(g.radius[i]))
            )
            ids.append(
                gm.addGeometryObject(
                    pin.GeometryObject(f"{g.links[i]}#{i}", int(g.joints[i]), M, shape)
                )
            )
        oids = []
        for o in self.obstacles:
            if o.shape == "halfspace":
                n_b = np.array(o.normal)
                n_w = T_world_base[:3, :3] @ n_b
                off = o.offset + float(n_w @ T_world_base[:3, 3])
                shape, M = coal.Halfspace(n_w, off), pin.SE3.Identity()
            else:
                shape = {
                    "box": lambda o: coal.Box(*o.size),
                    "sphere": lambda o: coal.Sphere(o.radius),
                    "cylinder": lambda o: coal.Cylinder(o.radius, o.length),
                    "capsule": lambda o: coal.Capsule(o.radius, o.length),
                }[o.shape](o)
                T = T_world_base @ o.T_base_obstacle
                M = pin.SE3(T[:3, :3], T[:3, 3])
            oids.append(gm.addGeometryObject(pin.GeometryObject(o.name, 0, M, shape)))
        pairs = [(ids[i], oids[k]) for i, k in self._obs_pairs]
        pairs += [(ids[i], ids[j]) for i, j in self._self_pairs]
        pairs = [(min(p), max(p)) for p in pairs]
        for p in pairs:
            gm.addCollisionPair(pin.CollisionPair(*p))
        return gm, list(self.pair_names), pairs

    def closest_pairs(
        self, q: np.ndarray, limit: int = 20
    ) -> list[tuple[tuple[str, str], float, np.ndarray, np.ndarray]]:
        """Per pair of names (closest capsule pair of each), closest first, at most ``limit``:
        ``(links, distance [m], point on the first, point on the second)``, points in the base frame
        (coal via pinocchio's ``computeDistances``)."""
        gm, names, pairs = self._geometry_model()
        names_of = {p: k for k, p in enumerate(pairs)}
        data, gdata = pin.Data(self.robot.model), pin.GeometryData(gm)
        pin.computeDistances(self.robot.model, data, gm, gdata, np.asarray(q, dtype=float))
        R, t = self._T_base_world[:3, :3], self._T_base_world[:3, 3]
        best: dict[tuple[str, str], tuple[float, np.ndarray, np.ndarray]] = {}
        for k, res in enumerate(gdata.distanceResults):
            cp = gm.collisionPairs[k]
            k = names_of[(cp.first, cp.second)]
            d = float(res.min_distance)
            if names[k] not in best or d < best[names[k]][0]:
                p1 = R @ np.asarray(res.getNearestPoint1()) + t
                p2 = R @ np.asarray(res.getNearestPoint2()) + t
                best[names[k]] = (d, p1, p2)
        rows = sorted(((n, *v) for n, v in best.items()), key=lambda r: r[1])
        return rows[:limit]


def link_shapes(
    robot: Robot, geometry: RobotCollision
) -> list[tuple[str, float, float, np.ndarray]]:
    """Each capsule as ``(link, radius [m], length [m], T_link_shape (4, 4))``: the shape's centre and
    its z axis along the segment, in the frame of ``link`` (the inverse of ``_attach``); length 0 is a
    sphere. The form of ``collision_geometry`` in a robot's description."""
    model = robot.model
    rows = []
    for i, link in enumerate(geometry.links):
        M_inv = model.frames[_link_frame_id(model, link)].placement.inverse()
        a, b = M_inv.act(geometry.a[i]), M_inv.act(geometry.b[i])
        length = float(np.linalg.norm(b - a))
        z = (b - a) / length if length > 1e-12 else np.array([0.0, 0.0, 1.0])
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = _frame_with_z(z), (a + b) / 2
        rows.append((link, float(geometry.radius[i]), length if length > 1e-12 else 0.0, T))
    return rows


def _frame_with_z(z: np.ndarray) -> np.ndarray:
    """A rotation whose third column is the unit vector ``z``."""
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def allowed_self_pairs(
    robot: Robot, geometry: RobotCollision, samples: int = SAMPLES_FOR_ALLOWED, seed: int = 0
) -> frozenset[frozenset[str]]:
    """Link pairs never checked for self-collision: adjacent links (one joint apart, or the same
    joint), pairs in contact in none of ``samples`` random configurations inside the limits
    (fewer when samples x pairs would exceed ``MAX_ALLOWED_WORK``, at least 500) (they
    cannot touch), and pairs in contact in all of them (built into the arm: never a planning error)."""
    links = sorted(set(geometry.links))
    joint_of = {n: int(j) for n, j in zip(geometry.links, geometry.joints, strict=True)}
    parents = robot.model.parents
    allowed = set()
    for a, b in itertools.combinations(links, 2):
        ja, jb = joint_of[a], joint_of[b]
        if ja == jb or parents[ja] == jb or parents[jb] == ja:
            allowed.add(frozenset((a, b)))
    checker = CollisionChecker(robot, geometry, allowed_self=frozenset(allowed))
    if checker.n_pairs:
        lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
        lo, hi = np.maximum(lo, -math.pi), np.minimum(hi, math.pi)
        samples = int(min(samples, max(500, MAX_ALLOWED_WORK // checker.n_pairs)))
        qs = np.random.default_rng(seed).uniform(lo, hi, size=(samples, robot.dof))
        rows = max(1, CHUNK_ENTRIES // checker.n_pairs)
        touch = np.vstack(
            [checker.distances(qs[k : k + rows]) < 0 for k in range(0, samples, rows)]
        )
        by_links: dict[frozenset[str], np.ndarray] = {}
        for p, name in enumerate(
            checker.pair_names
        ):  # a link pair touches if any capsule pair does
            key = frozenset(name)
            by_links[key] = by_links.get(key, np.zeros(samples, dtype=bool)) | touch[:, p]
        for key, t in by_links.items():
            if not t.any() or t.all():
                allowed.add(key)
    return frozenset(allowed)


_setup_cache: dict[tuple[str, int], tuple[RobotCollision, frozenset[frozenset[str]]]] = {}


def robot_setup(
    robot: Robot, urdf: str | None = None
) -> tuple[RobotCollision, frozenset[frozenset[str]]]:
    """A robot's capsules and allowed self pairs, computed once per robot (shipped or inline)."""
    key = (robot.name, id(robot))
    hit = _setup_cache.get(key)
    if hit is None:
        geometry = robot_collision(robot, urdf)
        hit = (geometry, allowed_self_pairs(robot, geometry))
        if len(_setup_cache) > 64:
            _setup_cache.clear()
        _setup_cache[key] = hit
    return hit


@dataclass(frozen=True)
class DamperInputs:
    """What ``core.clearance.velocity_damper_rows`` needs, for the pairs closer than an influence
    distance at one configuration (base frame).

    Attributes:
        pairs: ``(m,)`` indices into ``pair_names``.
        distances: ``(m,)`` [m].
        normals: ``(m, 3)`` unit, from the obstacle (or the second link) towards the robot point.
        point_jacobians: ``(m, 3, dof)`` linear Jacobian of the robot point (self pairs: of the
            first point minus the second), so that d' = n . (J qd).
    """

    pairs: np.ndarray
    distances: np.ndarray
    normals: np.ndarray
    point_jacobians: np.ndarray


def damper_inputs(check: CollisionChecker, q: np.ndarray, d_influence: float) -> DamperInputs:
    """Closest points (coal, through pinocchio's ``computeDistances``), normals and point Jacobians
    of every checked pair closer than ``d_influence`` [m] at ``q``: the rows of the velocity dampers
    of the DLS QP (``core.clearance``)."""
    robot = check.robot
    model = robot.model
    q = np.asarray(q, dtype=float)
    if check._coal is None:  # one coal workspace per checker: a control loop calls this per tick
        gm, _, pairs = check._geometry_model()
        index = {(cp.first, cp.second): k for k, cp in enumerate(gm.collisionPairs)}
        check._coal = (gm, pairs, index, pin.Data(model), pin.GeometryData(gm))
    gm, pairs, index, data, gdata = check._coal
    pin.computeDistances(model, data, gm, gdata, q)
    pin.computeJointJacobians(model, data, q)
    R = check._T_base_world[:3, :3]
    rows, dist, normals, jacs = [], [], [], []

    def point_jacobian(geom: int, p: np.ndarray) -> np.ndarray:
        joint = gm.geometryObjects[geom].parentJoint
        if joint == 0:
            return np.zeros((3, model.nv))
        J = pin.getJointJacobian(model, data, joint, pin.LOCAL_WORLD_ALIGNED)
        r = p - data.oMi[joint].translation
        skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        return J[:3] - skew @ J[3:]

    for p, (g1, g2) in enumerate(pairs):
        res = gdata.distanceResults[index[(g1, g2)]]
        d = float(res.min_distance)
        if d >= d_influence:
            continue
        p1, p2 = np.asarray(res.getNearestPoint1()), np.asarray(res.getNearestPoint2())
        gap = p1 - p2
        n = gap / np.linalg.norm(gap) if d > 1e-9 else -np.asarray(res.normal)
        J = point_jacobian(g1, p1) - point_jacobian(g2, p2)
        rows.append(p)
        dist.append(d)
        normals.append(R @ n)
        jacs.append(R @ J)
    m = len(rows)
    return DamperInputs(
        np.array(rows, dtype=int),
        np.array(dist),
        np.reshape(normals, (m, 3)),
        np.reshape(jacs, (m, 3, model.nv)),
    )
