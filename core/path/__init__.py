"""Cartesian path shapes: the ``PATHS`` registry (name -> implementation of ``core.path.base.Path``).

Adding a shape is one module implementing the ``Path`` Protocol plus one line here.
"""

from __future__ import annotations

from core.path.base import Path, PathDeviation
from core.path.line import StraightLine

PATHS: dict[str, type[Path]] = {"line": StraightLine}

__all__ = ["PATHS", "Path", "PathDeviation", "StraightLine"]
