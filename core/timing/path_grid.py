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
TURN = 0.2
"""Largest |d2q/ds2| / |dq/ds| times the grid spacing: the direction (in rad) and the relative
speed of the path change by about this much across one interval."""
MIN_PER_PIECE = 6
"""Fewest grid intervals between two breakpoints (a straight segment's switch from acceleration to
deceleration needs a few) while the path has at most ``PIECE_BUDGET / MIN_PER_PIECE`` pieces; a
path of more pieces gets ``PIECE_BUDGET`` / pieces each (at least one): short pieces of a long path
(840 waypoints of a program's answer) need no more."""
PIECE_BUDGET = 1200
"""Intervals the per-piece minimum may ask for in all."""
MAX_INTERVALS = 40_000
"""Most grid intervals (a path with more pieces than this gets one interval per piece)."""
NUDGE = 1e-10
"""One-sided samples sit this fraction of the interval inside it."""
JUMP = 1e-6
"""Relative jump of dq/ds at a breakpoint above which the motion must stop there."""


class PathSamples(NamedTuple):
    """q, dq/ds, d2q/ds2 at K path parameters, each ``(K, dof)``, and the path parameters ``s``
    ``(K,)`` (``PathLimits.rows(*samples)`` gets them: limits may vary along the path)."""

    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    s: np.ndarray


def sample_path(path: JointPath, s: np.ndarray) -> PathSamples:
    """q, dq/ds, d2q/ds2 of ``path`` at ``s`` ``(K,)``."""
    s = np.asarray(s, dtype=float)
    return PathSamples(path(s, 0), path(s, 1), path(s, 2), s)


class Grid(NamedTuple):
    """Grid ``s`` ``(N + 1,)`` from 0 to the path's length, ``breaks`` ``(N + 1,)`` True at the
    path's breakpoints (both ends included)."""

    s: np.ndarray
    breaks: np.ndarray


def path_grid(path: JointPath) -> Grid:
    """The grid of ``path`` (rules in the module docstring): every piece between breakpoints is
    cut into cells of at most 1/``BASE_INTERVALS`` of the path, and each cell into as many equal
    intervals as its largest |d2q/ds2| / |dq/ds| (five samples) asks for under ``TURN``."""
    length = float(path.length)
    b = np.asarray(path.breakpoints(), dtype=float)
    b = np.unique(np.clip(np.concatenate([[0.0, length], b]), 0.0, length))
    keep = np.diff(b) > 1e-12 * length
    b = np.concatenate([b[:-1][keep], [length]])
    pieces = np.diff(b)
    cells = np.maximum(1, np.ceil(pieces * BASE_INTERVALS / length)).astype(np.int64)
    piece = np.repeat(np.arange(len(pieces)), cells)
    k = np.arange(int(cells.sum())) - np.repeat(np.cumsum(cells) - cells, cells)
    width = (pieces / cells)[piece]
    left = b[:-1][piece] + k * width
    f = np.array([0.02, 0.25, 0.5, 0.75, 0.98])
    s = (left[:, None] + width[:, None] * f).ravel()
    dq, ddq = path(s, 1), path(s, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        bend = np.linalg.norm(ddq, axis=1) / np.linalg.norm(dq, axis=1)
    bend = np.nan_to_num(bend, nan=0.0, posinf=1e12).reshape(-1, len(f)).max(axis=1)
    fewest = int(np.clip(PIECE_BUDGET // max(len(pieces), 1), 1, MIN_PER_PIECE))
    n = np.ceil(width * np.maximum(bend, 1e-300) / TURN)
    n = np.maximum(n, np.ceil(fewest / cells[piece])).clip(1, None).astype(np.int64)
    if n.sum() > MAX_INTERVALS:
        share = max(MAX_INTERVALS - len(n), 0) / max(float((n - 1).sum()), 1.0)
        n = 1 + np.floor((n - 1) * min(share, 1.0)).astype(np.int64)
    j = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    grid = np.concatenate([np.repeat(left, n) + j * np.repeat(width / n, n), [length]])
    breaks = np.concatenate([(j == 0) & np.repeat(k == 0, n), [True]])
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
