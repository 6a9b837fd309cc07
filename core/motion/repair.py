"""Repairing the path of a lazy search: every segment certified, or replaced by a certified detour.

A lazy search (``core.motion.plan.find_path``) checks its tree edges only at configurations
``SEARCH_RESOLUTION`` apart; ``repair`` certifies each segment of the path it found
(``core.motion.certify``) and replaces a segment that is not by the path of a finer lazy search
between its ends (repaired in turn, ``REPAIR_DEPTH`` levels), and when that finds nothing new, by
the path of a search whose tree edges are certified as they grow (``Certifier.edge_ok``). Every
bound is a count (``REPAIR_QUESTIONS``), so the answer depends on the seed, not on the machine's
speed.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from core.motion.certify import Certifier
from core.motion.sampler import Sampler, SearchProblem

SEARCH_RESOLUTION = 0.15
"""[rad] Step of the lazy search's segment checks (its path is certified afterwards)."""
SEARCH_MARGIN = 0.0
"""[m] Extra clearance the lazy search asks of the configurations it checks."""
REPAIR_EDGE = 0.5
"""[rad] Longest tree edge of a repair search (its edges certified as they grow: shorter edges
are cheaper to certify than they cost in extra tree states, on the MBM Panda problems)."""
REPAIR_QUESTIONS = 3000
"""Most questions (configurations and certified segments) of one repair search: a segment that
cannot be repaired within them sends the search back to a fresh start (a count, not a time, so the
answer does not depend on the machine's speed)."""
REPAIR_DEPTH = 2
"""Levels of finer lazy searches a segment's repair tries before a certified search."""
REPAIR_REFINE = 3.0
"""Each level of repair checks segments this many times more finely."""


@dataclass(frozen=True)
class Repair:
    """What every search of one ``find_path`` shares."""

    certifier: Certifier
    lower: np.ndarray
    upper: np.ndarray
    sampler: Sampler
    end: float

    def run(
        self, a: np.ndarray, b: np.ndarray, seed: int, resolution: float | None
    ) -> np.ndarray | None:
        """A search from ``a`` to ``b``: lazy at ``resolution`` (its segments to be certified), or
        with every tree edge certified (``resolution`` None); at most ``REPAIR_QUESTIONS``."""
        left = self.end - time.perf_counter()
        if left <= 0:
            return None
        c = self.certifier
        lazy = resolution is not None
        found = self.sampler.search(
            SearchProblem(
                a, b[None], self.lower, self.upper,
                (lambda q: c.state_clear(q, SEARCH_MARGIN)) if lazy else c.state_ok,
                None if lazy else c.edge_ok, seed, left, REPAIR_QUESTIONS,
                resolution or SEARCH_RESOLUTION, REPAIR_EDGE,
            )
        )  # fmt: skip
        return found.path


def repair(search: Repair, path: np.ndarray, seed: int, depth: int = 0) -> np.ndarray | None:
    """``path`` with every segment certified. A segment that is not is replaced by the path of a
    lazy search between its ends at a finer resolution (``SEARCH_RESOLUTION`` /
    ``REPAIR_REFINE`` per level, repaired in turn, ``REPAIR_DEPTH`` levels), and when that finds
    nothing new, of a search whose tree edges are certified as they grow. None when a segment
    cannot be repaired within ``REPAIR_QUESTIONS`` per search (or before the time limit)."""
    out = [path[:1]]
    for a, b in itertools.pairwise(path):
        if search.certifier.path(np.vstack([a, b])).ok:
            out.append(b[None])
            continue
        fixed = None
        if depth < REPAIR_DEPTH:
            finer = SEARCH_RESOLUTION / REPAIR_REFINE ** (depth + 1)
            detour = search.run(a, b, seed, finer)
            if detour is not None and len(detour) > 2:
                fixed = repair(search, detour, seed, depth + 1)
        if fixed is None:
            fixed = search.run(a, b, seed, None)
        if fixed is None:
            return None
        out.append(fixed[1:])
    return np.vstack(out)


LAZY_REDUCE = True
"""Reduce the lazy path's vertices with the quick probe before certifying it (``reduced``)."""
REDUCE_TRIES = 8
"""Later knots the lazy vertex reduction tries from each kept knot (farthest first)."""


def reduced(search: Repair, path: np.ndarray, seed: int) -> np.ndarray | None:
    """``repair`` of the lazy search's ``path`` after a greedy vertex reduction that only probes
    (``Certifier.probably_clear``: a search tree's path of many short edges becomes a few long
    ones): each reduced segment is then certified, and one that is not falls back to the part of
    ``path`` it skipped, repaired segment by segment. So the segments certified are those kept,
    not the many a shortening would drop anyway."""
    if not LAZY_REDUCE:
        return repair(search, path, seed)
    keep, i, n = [0], 0, len(path)
    while i < n - 1:
        j = i + 1
        for far in range(n - 1, max(i + 1, n - 1 - REDUCE_TRIES), -1):
            if search.certifier.probably_clear(path[[i, far]]):
                j = far
                break
        keep.append(j)
        i = j
    out = [path[:1]]
    for a, b in itertools.pairwise(keep):
        if b > a + 1 and search.certifier.path(path[[a, b]]).ok:
            out.append(path[b][None])
            continue
        fixed = repair(search, path[a : b + 1], seed)
        if fixed is None:
            return None
        out.append(fixed[1:])
    return np.vstack(out)
