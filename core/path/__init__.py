"""Cartesian path shapes: the ``PATHS`` registry (name -> implementation of ``core.path.base.Path``).

Adding a shape is one module implementing the ``Path`` Protocol plus one line here.
"""

from __future__ import annotations

from core.path.arc import Arc
from core.path.base import Path, PathDeviation
from core.path.line import StraightLine

PATHS: dict[str, type[Path]] = {"line": StraightLine, "circ": Arc}

__all__ = ["PATHS", "Arc", "Path", "PathDeviation", "StraightLine"]
