"""A geometric joint path q(s): what a path timing law (``core.timing.topp``) times.

Timing only decides how fast s advances along a fixed geometric path, so re-timing never moves the
path. Every planner that hands a joint path to a timing law implements this Protocol: the retime
endpoint's spline and blended paths, a motion program's blended joint path, a collision-free
motion's smoothed knots. With q' = q_s s' and q'' = q_s s'' + q_ss s'^2, every joint velocity,
acceleration and effort limit is affine in (s'', s'^2) at a fixed s.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class JointPath(Protocol):
    """q(s) for s in [0, ``length``], ``dof`` joints.

    Attributes:
        length: End of the path parameter's domain (> 0; units are the path's own, for example
            rad of joint-space arc length).
        dof: Number of joints.
    """

    length: float
    dof: int

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """q [rad or m] (``order=0``), dq/ds (1) or d2q/ds2 (2) at path parameters ``s`` ``(K,)``:
        shape ``(K, dof)``; exact (analytic), never finite differences."""
        ...

    def breakpoints(self) -> np.ndarray:
        """Sorted path parameters ``(B,)`` where d2q/ds2 may jump (0 and ``length`` included): a
        timing grid contains them, so every grid interval is smooth."""
        ...


@runtime_checkable
class JoinedPath(JointPath, Protocol):
    """A ``JointPath`` whose d3q/ds3 (only) may jump at ``joins`` (a C2 spline's knots): a timing
    law need not put them in its grid, but checks its limits there (a limit's value may have a
    kink at a join)."""

    def joins(self) -> np.ndarray:
        """Sorted path parameters ``(J,)`` where d3q/ds3 may jump."""
        ...
