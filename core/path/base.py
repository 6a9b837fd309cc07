"""What a Cartesian path shape offers the planners: the ``Path`` Protocol and ``PathDeviation``.

A path runs over the path parameter s in [0, 1] from ``T_start`` to ``T_goal`` (4x4 ``T_base_tool``
each, base frame, meters). The planners only ever ask a path for poses at s, the derivative of the
pose along s (to turn joint rates into path rates), its extent (to turn tool speed limits into
limits on s'), and the closest-point deviation of poses from it (the dense self-check of every
returned trajectory). A new shape (``core/path/arc.py``: ``circ``) implements these members and is
added to ``core.path.PATHS`` with one line.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


@dataclass(frozen=True)
class PathDeviation:
    """Deviation of N poses from a path.

    Attributes:
        s: Closest path parameter of each pose, shape ``(N,)``.
        position: Distance [m] from each pose's position to the path point at ``s``, ``(N,)``.
        orientation: Angle [rad] between each pose's orientation and the path's at ``s``, ``(N,)``.
    """

    s: np.ndarray
    position: np.ndarray
    orientation: np.ndarray


class Path(Protocol):
    """A tool path over s in [0, 1] (see the module docstring).

    ``task_space`` is ``"pose"`` or ``"position_xy"`` (planar arms: only x and y count).
    """

    task_space: str
    T_start: np.ndarray
    T_goal: np.ndarray

    @property
    def length(self) -> float:
        """Distance [m] the tool travels along the path."""
        ...

    @property
    def angle(self) -> float:
        """Rotation [rad] the tool turns through."""
        ...

    def poses(self, s: np.ndarray) -> np.ndarray:
        """Tool poses ``T_base_tool`` ``(N, 4, 4)`` at path parameters ``s`` (N,)."""
        ...

    def pose(self, s: float) -> np.ndarray:
        """One tool pose (4, 4) at ``s``."""
        ...

    def derivative(self, s: np.ndarray) -> np.ndarray:
        """``(N, 6)`` derivative of the pose along s at ``s`` (N,): [dp/ds (m), omega/ds (rad)] in
        the base frame; the tool twist is ``derivative(s) * s'``."""
        ...

    def deviation(
        self, T: np.ndarray, position_tolerance: float = 1e-3, orientation_tolerance: float = 1e-2
    ) -> PathDeviation:
        """Closest-point deviation of poses ``T`` (N, 4, 4) from the path; the tolerances [m],
        [rad] only weigh position against orientation when choosing the closest point."""
        ...


class PosesFromParts:
    """``poses`` and ``pose`` of a path from its ``positions(s)`` (N, 3) and
    ``rotation_matrices(s)`` (N, 3, 3): the one assembly of ``T_base_tool`` both shapes share."""

    def positions(self, s: np.ndarray) -> np.ndarray:  # pragma: no cover - provided by the shape
        raise NotImplementedError

    def rotation_matrices(self, s: np.ndarray) -> np.ndarray:  # pragma: no cover - the shape's
        raise NotImplementedError

    def poses(self, s: np.ndarray) -> np.ndarray:
        """Tool poses ``T_base_tool`` at ``s`` (N,): shape (N, 4, 4)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        T = np.zeros((s.size, 4, 4))
        T[:, :3, :3] = self.rotation_matrices(s)
        T[:, :3, 3] = self.positions(s)
        T[:, 3, 3] = 1.0
        return T

    def pose(self, s: float) -> np.ndarray:
        """One tool pose (4, 4) at path parameter ``s``."""
        return self.poses(np.array([s]))[0]
