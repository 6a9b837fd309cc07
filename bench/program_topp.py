"""P7's reference: toppra 0.6.10 (TOPP-RA) on a program chunk's own joint path and limits.

The chunk's path (``core.program.chunk.ChunkPath``, the blended joint path the program timed)
goes to toppra through its geometric-path interface; its limits are the chunk's, every row of
``core.timing.path_constraints`` that ours keeps (joint velocity and acceleration times each
piece's scales, and for LIN/CIRC pieces the tool speed and the rate of change of the tool speed)
as one canonical linear constraint at toppra's grid points (``Rows``). toppra's result is then
measured here on a dense resampling in time (``DENSE`` points per grid interval): the largest
value of any of those limits over its bound, minus 1 (its "excess"; 0 when within).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bench.retime import toppra_path
from core.program.chunk import ChunkPath
from core.timing.path_constraints import PathLimits
from core.timing.path_grid import sample_path

DENSE = 20
"""Resampling points per grid interval when an answer's excess is measured."""


def toppra_on_chunk(
    path: ChunkPath, rows: PathLimits, gridpoints: np.ndarray | None = None
) -> tuple[Any, int]:
    """toppra's trajectory of ``path`` under ``rows`` (on ``gridpoints``, default its own) and
    its number of grid intervals."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    toppra.setup_logging("WARNING")

    class Rows(toppra.constraint.LinearConstraint):  # type: ignore[misc]
        """Every kept row of ``rows``: |a u + b x + c| <= h at each grid point."""

        def compute_constraint_params(self, _path, gridpoints):  # type: ignore[no-untyped-def]
            r = rows.rows(*sample_path(path, np.asarray(gridpoints, dtype=float)))
            h = rows.bounds
            m = len(h)
            F = np.vstack([np.eye(m), -np.eye(m)])
            g = np.concatenate([h, h])
            self.identical = True
            return r.A, r.B, r.C, F, g, None, None

    algo = toppra.algorithm.TOPPRA(
        [Rows()], toppra_path(path), gridpoints=gridpoints, parametrizer="ParametrizeConstAccel"
    )
    trajectory = algo.compute_trajectory()
    return trajectory, len(algo.problem_data.gridpoints) - 1


def excess(path: ChunkPath, rows: PathLimits, s_of_t: Any, duration: float, grid: int) -> float:
    """Largest value over bound of any row of ``rows`` minus 1, on ``DENSE * grid`` instants of a
    timing ``s_of_t(t, order)`` (s, s', s'') of ``path`` (0 when every limit holds; velocity rows
    compare speeds, not their squares)."""
    t = np.linspace(0.0, duration, DENSE * grid + 1)
    s, sd, sdd = (np.asarray(s_of_t(t, k), dtype=float).ravel() for k in range(3))
    r = rows.rows(*sample_path(path, np.clip(s, 0.0, path.length)))
    value = np.abs(r.A * sdd[:, None] + r.B * (sd * sd)[:, None] + r.C) / rows.bounds
    squared = np.array([kind in ("velocity", "linear_speed", "angular_speed")
                        for kind, _ in rows.labels()])  # fmt: skip
    value[:, squared] = np.sqrt(value[:, squared])
    return max(0.0, float(value.max()) - 1.0)
