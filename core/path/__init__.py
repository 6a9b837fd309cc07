"""Cartesian path shapes: the ``PATHS`` registry (name -> implementation of ``core.path.base.Path``).

Adding a shape is one module implementing the ``Path`` Protocol plus one line here.
"""

from __future__ import annotations

import numpy as np

from core.errors import InputError
from core.path.arc import Arc
from core.path.base import Path, PathDeviation
from core.path.line import StraightLine

PATHS: dict[str, type[Path]] = {"line": StraightLine, "circ": Arc}


def build_path(
    kind: str,
    T_start: np.ndarray,
    T_goal: np.ndarray,
    task_space: str = "pose",
    *,
    interim: np.ndarray | None = None,
    center: np.ndarray | None = None,
    field: tuple[str | int, ...] = (),
) -> Path:
    """The path ``kind`` (a ``PATHS`` name) from ``T_start`` to ``T_goal`` (4x4 each): ``"line"``
    takes no circle; ``"circ"`` takes exactly one of ``interim`` / ``center`` [m]. ``InputError``
    at ``field`` (+ ``"type"``, ``"interim"``, ``"center"``) for an unknown kind or bad geometry.
    For ``position_xy`` the circle lies in the start's z plane (``interim``/``center`` keep x, y)."""
    if kind == "line":
        if interim is not None or center is not None:
            raise InputError("a line takes no interim or center", field=(*field, "type"))
        return StraightLine(T_start, T_goal, task_space)
    if kind == "circ":
        if task_space == "position_xy":
            z = float(np.asarray(T_start)[2, 3])
            interim = None if interim is None else np.array([interim[0], interim[1], z])
            center = None if center is None else np.array([center[0], center[1], z])
        return Arc(
            T_start, T_goal, interim=interim, center=center, task_space=task_space, field=field
        )
    raise InputError(f"path.type must be one of {', '.join(PATHS)}", field=(*field, "type"))


__all__ = ["PATHS", "Arc", "Path", "PathDeviation", "StraightLine", "build_path"]
