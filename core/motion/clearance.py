"""What a collision-free motion search asks of the collision model: ``GroupClearance``.

It is a ``core.kinematics.Clearance`` (distances, thresholds, motion weights, continuous check,
close pairs) that can also answer for a few of its pairs at one configuration, cheaply: a sampling
search evaluates tens of thousands of configurations, most of them for the one or two pairs whose
motion bound is not yet proven (``core.motion.certify``). ``robots.validity.GroupedClearance``
implements it with coal, each "pair" being a group of the checker's pairs (one robot link against
the obstacles, or against the other links).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from core.kinematics import Clearance, PathCheck


@runtime_checkable
class GroupClearance(Clearance, Protocol):
    """A ``Clearance`` that answers for chosen pairs at one configuration and names its closest."""

    def pair_distances(self, q: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        """Signed distances ``(len(pairs),)`` [m] of pairs ``pairs`` (indices) at ``q`` ``(dof,)``."""
        ...

    def collides(self, q: np.ndarray, margin: float) -> bool:
        """Is any pair closer than its threshold plus ``margin`` [m] at ``q`` ``(dof,)``? The
        fast yes/no question of a search (no distances)."""
        ...

    def closest_pair(self, q: np.ndarray) -> tuple[tuple[str, str], float, float]:
        """The real pair (names) with the smallest margin over its threshold at ``q``, its
        distance [m] and its threshold [m]."""
        ...


@dataclass(frozen=True)
class _NothingChecked:
    """The ``PathCheck`` of a motion with no pair to check: clear, no closest pair."""

    contact: None = None
    min_clearance: float = math.inf
    closest: None = None
    evaluations: int = 0


NOTHING_CHECKED = _NothingChecked()


class Unobstructed:
    """The clearance of a robot with nothing to collide with (no geometry, or no pair checked):
    no pairs, every configuration and segment clear."""

    def __init__(self, dof: int) -> None:
        self.pair_names: list[tuple[str, str]] = []
        self.threshold = np.zeros(0)
        self.motion_weights = np.zeros((0, dof))

    def distances(self, qs: np.ndarray) -> np.ndarray:
        return np.zeros((len(np.atleast_2d(qs)), 0))

    def check_path(self, times: np.ndarray, qs: np.ndarray) -> PathCheck:
        return NOTHING_CHECKED

    def close_pairs(
        self, q: np.ndarray, d_influence: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        dof = self.motion_weights.shape[1]
        return np.zeros(0, dtype=int), np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3, dof))

    def pair_distances(self, q: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        return np.zeros(0)

    def collides(self, q: np.ndarray, margin: float) -> bool:
        return False

    def closest_pair(self, q: np.ndarray) -> tuple[tuple[str, str], float, float]:
        raise ValueError("no pair is checked")
