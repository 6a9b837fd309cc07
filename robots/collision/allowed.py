"""Which self pairs a robot never checks (``allowed_self_collisions``), and the per-robot setup cache.

Adjacent links (one joint apart, or on the same joint), link pairs in contact in none of
``SAMPLES_FOR_ALLOWED`` random configurations inside the limits (they cannot touch), and pairs in
contact in all of them (built into the arm: never a planning error).
"""

from __future__ import annotations

import itertools
import math
import threading
import weakref

import numpy as np

from robots.collision.building import robot_collision
from robots.collision.checker import CollisionChecker
from robots.collision.continuous import ENTRY_CHUNK
from robots.collision.shapes import RobotCollision
from robots.model import Robot

SAMPLES_FOR_ALLOWED = 4000
"""Random configurations that decide which self pairs never touch (``allowed_self_collisions``)."""
MAX_ALLOWED_WORK = 2_000_000
"""Most pair distances spent on that decision for one robot (inline URDFs with many primitives)."""


def allowed_self_pairs(
    robot: Robot, geometry: RobotCollision, samples: int = SAMPLES_FOR_ALLOWED, seed: int = 0
) -> frozenset[frozenset[str]]:
    """Link pairs never checked for self-collision (module docstring); ``samples`` is lowered when
    samples x pairs would exceed ``MAX_ALLOWED_WORK`` (at least 500)."""
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
        rows = max(1, ENTRY_CHUNK // checker.n_pairs)
        touch = np.vstack(
            [checker.distances(qs[k : k + rows]) < 0 for k in range(0, samples, rows)]
        )
        by_links: dict[frozenset[str], np.ndarray] = {}
        for p, name in enumerate(checker.pair_names):  # a link pair touches if any shape pair does
            key = frozenset(name)
            by_links[key] = by_links.get(key, np.zeros(samples, dtype=bool)) | touch[:, p]
        for key, t in by_links.items():
            if not t.any() or t.all():
                allowed.add(key)
    return frozenset(allowed)


_setup_cache: weakref.WeakKeyDictionary[Robot, tuple[RobotCollision, frozenset[frozenset[str]]]]
_setup_cache = weakref.WeakKeyDictionary()  # as long as the robot lives (the registry bounds them)
_setup_lock = threading.Lock()


def robot_setup(
    robot: Robot, urdf: str | None = None
) -> tuple[RobotCollision, frozenset[frozenset[str]]]:
    """A robot's shapes and allowed self pairs, computed once per robot (shipped or inline; a robot
    with a tool offset shares its arm's: the tool frame carries no geometry)."""
    base = robot.arm
    hit = _setup_cache.get(base)
    if hit is None:
        geometry = robot_collision(base, urdf)
        hit = (geometry, allowed_self_pairs(base, geometry))
        with _setup_lock:
            _setup_cache[base] = hit
    return hit
