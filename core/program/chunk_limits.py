"""The limits along one chunk of a program: each piece's scaled joint limits and tool limits.

A chunk's pieces (segments' own parts and blends, ``core.program.pieces.Piece``) each carry their
segment's velocity and acceleration scales and tool speed and acceleration limits (a blend: the
smaller of its two segments'; a PTP: no tool limit). ``chunk_limits`` gives them to a timing law of
``core.timing.TIMING_LAWS`` in both forms it may read (``core.timing.path_limits.PathLimits``):

- at the chunk's samples (``s``, ``velocity``, ``acceleration``, ``tool_speed``, ...), for the laws
  that cap s' and s'' on a grid (``jerk_limited``, ``s_curve``);
- as rows affine in (s'', s'^2) at any s (``rows``, ``core.timing.path_constraints.PathLimits``),
  for ``time_optimal``: the robot's joint limits, the tool's speed and the rate of change of its
  speed from the Jacobian (``core.timing.path_constraints.tool_rates``,
  ``core.timing.tool_path.tool_accelerations``), the program's effort limits, each scaled at every
  s by the piece it lies in (``PieceScales``; at a junction, the smaller of the two pieces').
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.kinematics import jacobians
from core.program.chunk import ChunkPath
from core.program.piece import Piece
from core.program.segments import ProgramTask
from core.timing.path_constraints import PathLimits as Rows
from core.timing.path_constraints import ToolAcceleration, ToolSpeed, tool_rates
from core.timing.path_limits import PathLimits
from core.timing.tool_path import tool_accelerations


@dataclass(frozen=True)
class PieceScales:
    """Factors of every row's bound per piece of a chunk (``LocalBounds``).

    Attributes:
        bounds: ``(P + 1,)`` the pieces' ends in the chunk's s, increasing from 0 to 1.
        factors: ``(P, n)`` each piece's factor of every row's bound (``Rows.labels`` order, all
            rows), inf where the piece has no such limit.
    """

    bounds: np.ndarray
    factors: np.ndarray

    def __call__(self, s: np.ndarray) -> np.ndarray:
        """``(K, n)`` factors at ``s`` ``(K,)``: the piece's that holds s, the smaller of two at a
        junction."""
        last = len(self.factors) - 1
        lo = np.clip(np.searchsorted(self.bounds, s, side="left") - 1, 0, last)
        hi = np.clip(np.searchsorted(self.bounds, s, side="right") - 1, 0, last)
        return np.minimum(self.factors[lo], self.factors[hi])


def _factors(piece: Piece, dof: int, effort: bool) -> np.ndarray:
    """One piece's factors of the rows (velocity rows squared; tool limits over a bound of 1)."""
    speed = np.asarray(piece.tool_speed, dtype=float)
    acc = np.asarray(piece.tool_acc, dtype=float)
    return np.concatenate([
        np.full(dof, piece.scales[0] ** 2), np.full(dof, piece.scales[1]), speed**2, acc,
        np.ones(dof if effort else 0),
    ])  # fmt: skip


def rows_of(task: ProgramTask, chunk: list[Piece], bounds: np.ndarray) -> Rows:
    """The chunk's limits as rows at any s (module docstring); ``bounds`` ``(P + 1,)``: each
    piece's first s and the chunk's end."""
    robot = task.robot
    finite = [np.isfinite([*p.tool_speed, *p.tool_acc]) for p in chunk]
    tool = np.any(finite, axis=0)  # which tool limits some piece has
    return Rows(
        np.asarray(robot.velocity_limits, dtype=float),
        np.asarray(robot.acceleration_limits, dtype=float),
        tool=ToolSpeed(tool_rates(robot), *(1.0 if t else None for t in tool[:2]))
        if tool[:2].any()
        else None,
        effort=task.effort,
        tool_acceleration=ToolAcceleration(
            tool_accelerations(robot), *(1.0 if t else None for t in tool[2:])
        )
        if tool[2:].any()
        else None,
        local=PieceScales(
            np.asarray(bounds, dtype=float),
            np.stack([_factors(p, robot.dof, task.effort is not None) for p in chunk]),
        ),
    )


def chunk_limits(
    task: ProgramTask, chunk: list[Piece], path: ChunkPath, keep: np.ndarray, starts: list[int]
) -> PathLimits:
    """The chunk's ``PathLimits`` at its kept samples (``keep`` over the pieces' joined samples;
    ``starts``: each piece's first joined sample), with its ``rows``."""
    robot = task.robot
    rows: dict[str, list[np.ndarray]] = {"v": [], "a": [], "ts": [], "ta": []}
    for k, p in enumerate(chunk):
        first = 0 if k == 0 else 1  # pieces share their junction sample
        n = len(p.q) - first
        rows["v"].append(np.tile(robot.velocity_limits * p.scales[0], (n, 1)))
        rows["a"].append(np.tile(robot.acceleration_limits * p.scales[1], (n, 1)))
        rows["ts"].append(np.tile(p.tool_speed, (n, 1)))
        rows["ta"].append(np.tile(p.tool_acc, (n, 1)))
    v, a, ts, ta = (np.concatenate(rows[key])[keep] for key in ("v", "a", "ts", "ta"))
    # the tool's own positions along the joint path (FK of its samples): what the jerk-limited
    # law bounds
    tool = robot.fk_many(path.samples)[:, :3, 3]
    # The tool's rate per unit s: J dq/ds (exact for the joint path, on or off the line).
    J = jacobians(robot, path.samples)
    twist = np.einsum("nij,nj->ni", J, path(path.knots, 1))
    rate = np.stack([np.linalg.norm(twist[:, :3], axis=1), np.linalg.norm(twist[:, 3:], axis=1)])
    asking = [
        task.segments[p.owner].tool_jerks()
        for p in chunk
        if not p.blend and task.segments[p.owner].cartesian
    ]
    jerk = tuple(np.min(asking, axis=0).tolist()) if asking else None
    index = np.cumsum(keep) - 1  # joined sample -> kept sample
    bounds = np.append(path.knots[index[starts]], path.length)
    return PathLimits(
        path.knots, v, a, rate.T, ts, ta, tool, jerk,  # type: ignore[arg-type]
        rows=rows_of(task, chunk, bounds),
    )  # fmt: skip
