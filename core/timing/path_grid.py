"""The grid a path timing law works on, and one-sided samples of a joint path.

``path_grid`` puts every breakpoint of the path (``JointPath.breakpoints``: where d2q/ds2 may jump)
into the grid, so every grid interval is smooth, and splits each piece between breakpoints so that
the path's direction and speed change little across an interval (|d2q/ds2| / |dq/ds| times the
spacing at most ``TURN``) and no interval is longer than 1/``BASE_INTERVALS`` of the path.
``sample_path`` evaluates q, dq/ds, d2q/ds2 at once; ``one_sided`` does it on one side of the
breakpoints (a hair inside the interval), where d2q/ds2 (or dq/ds at a reversal) jumps.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from core.timing.joint_path import JointPath

BASE_INTERVALS = 100
"""Grid intervals of a path without curvature (a straight line)."""
TURN = 0.3
"""Largest |d2q/ds2| / |dq/ds| times the grid spacing: the direction (in rad) and the relative
speed of the path change by about this much across one interval."""
MIN_PER_PIECE = 6
"""Fewest grid intervals between two breakpoints (a straight segment's switch from acceleration to
deceleration needs a few)."""
MAX_INTERVALS = 60_000
"""Most grid intervals (a path with more pieces than this gets one interval per piece)."""
NUDGE = 1e-10
"""One-sided samples sit this fraction of the interval inside it."""
JUMP = 1e-6
"""Relative jump of dq/ds at a breakpoint above which the motion must stop there."""


class PathSamples(NamedTuple):
    """q, dq/ds, d2q/ds2 at K path parameters, each ``(K, dof)``."""

    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray


def sample_path(path: JointPath, s: np.ndarray) -> PathSamples:
    """q, dq/ds, d2q/ds2 of ``path`` at ``s`` ``(K,)``."""
    return PathSamples(path(s, 0), path(s, 1), path(s, 2))


class Grid(NamedTuple):
    """Grid ``s`` ``(N + 1,)`` from 0 to the path's length, ``breaks`` ``(N + 1,)`` True at the
    path's breakpoints (both ends included)."""

    s: np.ndarray
    breaks: np.ndarray


def path_grid(path: JointPath) -> Grid:
    """The grid of ``path`` (rules in the module docstring)."""
    length = float(path.length)
    b = np.asarray(path.breakpoints(), dtype=float)
    b = np.unique(np.clip(np.concatenate([[0.0, length], b]), 0.0, length))
    pieces = np.diff(b)
    keep = pieces > 1e-12 * length
    b = np.concatenate([b[:-1][keep], [length]])
    pieces = np.diff(b)
    f = np.array([0.02, 0.25, 0.5, 0.75, 0.98])
    s = (b[:-1, None] + pieces[:, None] * f).ravel()
    dq, ddq = path(s, 1), path(s, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        bend = np.linalg.norm(ddq, axis=1) / np.linalg.norm(dq, axis=1)
    bend = np.nan_to_num(bend, nan=0.0, posinf=1e12).reshape(-1, len(f)).max(axis=1)
    spacing = np.minimum(length / BASE_INTERVALS, TURN / np.maximum(bend, 1e-300))
    n = np.maximum(MIN_PER_PIECE, np.ceil(pieces / spacing)).astype(np.int64)
    if n.sum() > MAX_INTERVALS:
        share = max(MAX_INTERVALS - len(n), 0) / max(float((n - 1).sum()), 1.0)
        n = 1 + np.floor((n - 1) * min(share, 1.0)).astype(np.int64)
    start = np.repeat(np.cumsum(n) - n, n)
    j = np.arange(int(n.sum())) - start
    grid = np.concatenate([np.repeat(b[:-1], n) + j * np.repeat(pieces / n, n), [length]])
    breaks = np.concatenate([j == 0, [True]])
    return Grid(grid, breaks)


def one_sided(
    path: JointPath, s: np.ndarray, breaks: np.ndarray, width: np.ndarray, side: float
) -> PathSamples:
    """Samples at ``s`` ``(K,)``, moved by ``side * NUDGE * width`` where ``breaks`` (``side``
    +1: the piece after a breakpoint, -1: the piece before it)."""
    at = np.where(breaks, s + side * NUDGE * width, s)
    return sample_path(path, at)


def stops(path: JointPath, grid: Grid) -> np.ndarray:
    """``(N + 1,)`` True at the interior breakpoints where dq/ds jumps (a reversal): the motion
    must be at rest there."""
    s, breaks = grid.s, grid.breaks.copy()
    breaks[[0, -1]] = False
    out = np.zeros(len(s), dtype=bool)
    idx = np.flatnonzero(breaks)
    if idx.size == 0:
        return out
    width = np.minimum(s[idx] - s[idx - 1], s[idx + 1] - s[idx])
    before = path(s[idx] - NUDGE * width, 1)
    after = path(s[idx] + NUDGE * width, 1)
    scale = np.maximum(np.linalg.norm(before, axis=1), np.linalg.norm(after, axis=1))
    out[idx] = np.linalg.norm(after - before, axis=1) > JUMP * np.maximum(scale, 1e-300)
    return out
