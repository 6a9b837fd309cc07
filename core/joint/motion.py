"""The input of a point-to-point joint move: the boundary states at both ends.

Units: positions [rad or m], velocities per [s], accelerations per [s^2]; arrays ``(dof,)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from core.errors import InputError
from core.limits import joint_vector


class State(NamedTuple):
    """Boundary conditions at one end, each ``(dof,)``: [rad or m], per [s], per [s^2]."""

    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


@dataclass(frozen=True)
class PointToPoint:
    """A joint-space move from ``start`` to ``goal`` (field names as in the API)."""

    start: State
    goal: State

    @classmethod
    def create(
        cls,
        start_positions: ArrayLike,
        goal_positions: ArrayLike,
        start_velocities: ArrayLike | None = None,
        goal_velocities: ArrayLike | None = None,
        start_accelerations: ArrayLike | None = None,
        goal_accelerations: ArrayLike | None = None,
    ) -> PointToPoint:
        """Validated move; missing rates are zero. ``InputError`` names the field at fault."""
        dof = int(np.size(start_positions))
        if np.ndim(start_positions) != 1 or dof == 0:
            raise InputError(
                "start.positions needs one value per joint", field=("start", "positions")
            )

        def state(end: str, q: object, v: object, a: object) -> State:
            return State(
                joint_vector(q, dof, (end, "positions")),
                joint_vector(v, dof, (end, "velocities"), default=0.0),
                joint_vector(a, dof, (end, "accelerations"), default=0.0),
            )

        return cls(
            state("start", start_positions, start_velocities, start_accelerations),
            state("goal", goal_positions, goal_velocities, goal_accelerations),
        )

    @property
    def dof(self) -> int:
        return int(self.start.positions.size)

    @property
    def distance(self) -> np.ndarray:
        """``|goal - start|`` per joint, ``(dof,)``."""
        return np.abs(self.goal.positions - self.start.positions)

    @property
    def at_rest(self) -> bool:
        """True when every boundary velocity and acceleration is zero."""
        return not any(
            np.any(x.velocities) or np.any(x.accelerations) for x in (self.start, self.goal)
        )
