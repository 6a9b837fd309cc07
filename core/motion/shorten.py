"""Shortening a certified joint path with certified shortcuts.

Two passes over the straight joint segments through the knots, every new segment certified
(``core.motion.certify``, after a quick probe that refuses most candidates cheaply) before it
replaces what it skips:

1. Vertex reduction: from each kept knot, the farthest later knot joined by a certified segment
   (deterministic; a search tree's path of many short edges becomes a few long ones).
2. Random shortcuts (Geraerts and Overmars 2007): two points drawn on the path by arc length (any
   point of a segment, not only knots), joined by a certified segment when that is shorter, from
   a generator seeded by the request; it stops after ``MAX_FAILURES`` failures in a row or
   ``MAX_SHORTCUTS`` tries.

The work is bounded by counts, never by the clock, so the same path and seed always give the same
result; the request's deadline only turns a run that is too slow into ``TimeBudgetExceeded``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.motion.certify import Certifier

MAX_SHORTCUTS = 20
"""Most random shortcuts tried."""
MAX_FAILURES = 5
"""Random shortcuts that fail in a row before the pass ends."""
SHORTCUT_EVALUATIONS = 150
"""Work bound of one shortcut's certification (a segment that needs more is not taken)."""
REDUCE_TRIES = 8
"""Later knots the vertex reduction tries from each kept knot (farthest first)."""
MIN_GAIN = 1e-6
"""[rad] A shortcut must shorten the path by at least this."""


@dataclass(frozen=True)
class Shortened:
    """A shortened path.

    Attributes:
        knots: ``(K, dof)``: the first and last are the input's; every segment certified.
        tries: Segments certified (kept or not).
    """

    knots: np.ndarray
    tries: int


def path_length(knots: np.ndarray) -> float:
    """Joint-space length [rad] of the straight segments through ``knots``: sum of |dq| (2-norm)."""
    return float(np.linalg.norm(np.diff(np.asarray(knots, dtype=float), axis=0), axis=1).sum())


def shorten(
    certifier: Certifier,
    knots: np.ndarray,
    rng: np.random.Generator,
    deadline: Deadline = NO_DEADLINE,
) -> Shortened:
    """Shorten ``knots`` ``(K, dof)`` (a certified path) by vertex reduction, then random
    shortcuts drawn from ``rng``."""
    knots, tries = _reduce(certifier, np.asarray(knots, dtype=float), deadline)
    failures = 0
    for _ in range(MAX_SHORTCUTS):
        deadline.check("shortening the path")
        if failures >= MAX_FAILURES or len(knots) < 3:
            break
        cand = _shortcut(knots, rng)
        if cand is None:
            failures += 1
            continue
        i, a, j, b = cand
        tries += 1
        pair = np.vstack([a, b])
        if certifier.probably_clear(pair) and certifier.path(pair, SHORTCUT_EVALUATIONS).ok:
            knots = np.vstack([knots[: i + 1], a[None], b[None], knots[j + 1 :]])
            knots = _dedupe(knots)
            failures = 0
        else:
            failures += 1
    return Shortened(knots, tries)


def _reduce(certifier: Certifier, knots: np.ndarray, deadline: Deadline) -> tuple[np.ndarray, int]:
    """Greedy vertex reduction: ``(knots kept, segments tried)``; from each kept knot at most
    ``REDUCE_TRIES`` later knots are tried, farthest first."""
    keep, i, tries = [0], 0, 0
    n = len(knots)
    while i < n - 1:
        j = i + 1
        for far in range(n - 1, max(i + 1, n - 1 - REDUCE_TRIES), -1):
            deadline.check("shortening the path")
            tries += 1
            pair = knots[[i, far]]
            if certifier.probably_clear(pair) and certifier.path(pair, SHORTCUT_EVALUATIONS).ok:
                j = far
                break
        keep.append(j)
        i = j
    return knots[keep], tries


def _shortcut(
    knots: np.ndarray, rng: np.random.Generator
) -> tuple[int, np.ndarray, int, np.ndarray] | None:
    """Two points on different segments, drawn uniformly by arc length, when joining them
    shortens the path: ``(segment of a, a, segment of b, b)`` (a before b)."""
    seg = np.linalg.norm(np.diff(knots, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    x, y = np.sort(rng.uniform(0.0, cum[-1], 2))
    i = int(np.clip(np.searchsorted(cum, x, side="right") - 1, 0, len(seg) - 1))
    j = int(np.clip(np.searchsorted(cum, y, side="right") - 1, 0, len(seg) - 1))
    if j <= i:
        return None
    a = knots[i] + (x - cum[i]) / max(seg[i], 1e-300) * (knots[i + 1] - knots[i])
    b = knots[j] + (y - cum[j]) / max(seg[j], 1e-300) * (knots[j + 1] - knots[j])
    if np.linalg.norm(b - a) >= y - x - MIN_GAIN:
        return None
    return i, a, j, b


def _dedupe(knots: np.ndarray) -> np.ndarray:
    """``knots`` without consecutive duplicates (a shortcut ending on a knot)."""
    step = np.linalg.norm(np.diff(knots, axis=0), axis=1)
    return knots[np.r_[True, step > 1e-12]]
