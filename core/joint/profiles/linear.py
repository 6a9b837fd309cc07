"""The linear point-to-point profile (registry entry ``linear``): constant velocity, rest to rest.

Units: positions [rad or m], times [s]; arrays ``(dof,)`` or ``(N, dof)``.
"""

from __future__ import annotations

import numpy as np

from core.joint import durations
from core.joint.motion import PointToPoint
from core.joint.profiles.base import DurationProfileKind, EndPinned
from core.limits import JointLimits
from core.trajectory import Peaks

STEP_WARNING = (
    "linear: the velocity steps from 0 to |dq|/T at the start and back to 0 at the end "
    "(unbounded acceleration at those instants); reported accelerations are 0"
)


class LinearProfile(EndPinned):
    """Constant velocity ``dq / T`` from ``q0`` to ``q1``; accelerations are reported as zero.

    Honest about the ends: the true velocity steps from 0 to ``dq / T`` at ``t = 0`` and back to 0
    at ``t = T`` (unbounded acceleration there). The samples at ``t == 0`` and ``t == T`` report the
    rest state (velocity exactly 0), because the ROS 2 joint trajectory controller requires zero
    velocity at the last point of a rest-to-rest plan; interior samples report ``dq / T``.
    """

    method = "linear"

    def __init__(self, q0: np.ndarray, q1: np.ndarray, duration: float) -> None:
        self.duration = float(duration)
        self.q0, self.dq = q0, q1 - q0
        zero = np.zeros_like(q0)
        self._start, self._goal = (q0, zero, zero), (q1, zero, zero)

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        s = (t / self.duration)[:, None]
        if order == 0:
            return self.q0 + self.dq * s
        if order == 1:
            return np.broadcast_to(self.dq / self.duration, (t.size, self.dq.size)).copy()
        return np.zeros((t.size, self.dq.size))

    def peaks(self) -> Peaks:
        """Cruise speed ``|dq| / T``, zero acceleration and jerk (the end steps are not counted),
        each ``(dof,)``."""
        zero = np.zeros_like(self.dq)
        return Peaks(np.abs(self.dq) / self.duration, zero, zero.copy())


class Linear(DurationProfileKind):
    """Constant velocity; held to the velocity limits only (its end steps are declared)."""

    name = "linear"
    rated = ("velocity",)
    needs = "velocity"

    def build(
        self, motion: PointToPoint, duration: float | np.ndarray, max_acceleration: np.ndarray
    ) -> LinearProfile:
        return LinearProfile(motion.start.positions, motion.goal.positions, float(duration))

    def _shortest(self, motion: PointToPoint, limits: JointLimits) -> float:
        return durations.linear_duration(motion.distance, limits.maxima(motion.dof)[0])

    def warnings(self, motion: PointToPoint) -> tuple[str, ...]:
        return (STEP_WARNING, *super().warnings(motion))
