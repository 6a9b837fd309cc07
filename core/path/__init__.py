"""Cartesian path shapes: the ``PATHS`` registry (name -> a builder of a ``core.path.base.Path``).

A builder takes the start and goal tool poses, the task space and the optional circle geometry
(``interim``, ``center`` [m]) and returns the path, or raises ``InputError`` at ``field`` (+ the
member at fault). The names are the request's ``path.type`` (a Cartesian request) and, through
``core.program``, the shapes of LIN (``line``) and CIRC (``circ``) segments. Adding a shape is one
module implementing the ``Path`` Protocol plus one line here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from core.errors import InputError
from core.path.arc import Arc
from core.path.base import Path, PathDeviation
from core.path.line import StraightLine

Field = tuple[str | int, ...]
PathBuilder = Callable[..., Path]
"""``(T_start, T_goal, task_space, *, interim, center, field) -> Path``."""


def line(
    T_start: np.ndarray,
    T_goal: np.ndarray,
    task_space: str = "pose",
    *,
    interim: np.ndarray | None = None,
    center: np.ndarray | None = None,
    field: Field = (),
) -> Path:
    """The straight line (lerp + slerp); it takes no circle geometry."""
    if interim is not None or center is not None:
        raise InputError("a line takes no interim or center", field=(*field, "type"))
    return StraightLine(T_start, T_goal, task_space)


def circ(
    T_start: np.ndarray,
    T_goal: np.ndarray,
    task_space: str = "pose",
    *,
    interim: np.ndarray | None = None,
    center: np.ndarray | None = None,
    field: Field = (),
) -> Path:
    """The circle arc through ``interim`` or about ``center``; for ``position_xy`` the circle lies
    in the start's z plane (``interim``/``center`` keep x, y)."""
    if task_space == "position_xy":
        z = float(np.asarray(T_start)[2, 3])
        interim = None if interim is None else np.array([interim[0], interim[1], z])
        center = None if center is None else np.array([center[0], center[1], z])
    return Arc(T_start, T_goal, interim=interim, center=center, task_space=task_space, field=field)


PATHS: dict[str, PathBuilder] = {"line": line, "circ": circ}


def build_path(
    kind: str,
    T_start: np.ndarray,
    T_goal: np.ndarray,
    task_space: str = "pose",
    *,
    interim: np.ndarray | None = None,
    center: np.ndarray | None = None,
    field: Field = (),
) -> Path:
    """The path ``kind`` (a ``PATHS`` name) from ``T_start`` to ``T_goal`` (4x4 each); ``InputError``
    at ``field`` (+ ``"type"``, ``"interim"``, ``"center"``) for an unknown kind or bad geometry."""
    builder = PATHS.get(kind)
    if builder is None:
        raise InputError(f"path.type must be one of {', '.join(PATHS)}", field=(*field, "type"))
    return builder(T_start, T_goal, task_space, interim=interim, center=center, field=field)


__all__ = ["PATHS", "Arc", "Path", "PathBuilder", "PathDeviation", "StraightLine", "build_path"]
