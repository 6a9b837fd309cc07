"""The trapezoidal point-to-point profile (registry entry ``trapezoidal``): synchronized joints.

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
    "trapezoidal: the acceleration steps at the start and end of each ramp (unbounded jerk at "
    "those instants); peak_jerk counts the pieces between the steps"
)


class TrapezoidalProfile(EndPinned):
    """Synchronized trapezoidal velocity, rest to rest: every joint starts and ends with the others.

    Each joint accelerates at ``a_j`` for ``ta_j``, cruises at ``v_j`` and decelerates for ``ta_j``,
    with ``v_j = 2|dq_j| / (T + sqrt(T^2 - 4|dq_j|/a_j))`` (the lower cruise speed that covers
    ``|dq_j|`` in ``T``; a triangle when ``T^2 = 4|dq_j|/a_j``). The joint-space path is therefore
    not a straight line. Accelerations are piecewise constant: at a switch the sample reports the
    phase that starts there, and at ``t == T`` the deceleration.

    Args:
        q0, q1: Start and goal positions ``(dof,)``.
        duration: ``T`` in [s].
        acceleration: ``a_j`` ``(dof,)`` [rad/s^2 or m/s^2]; ``inf`` entries (unknown limit) use
            ``4.5 |dq| / T^2`` (ramps of ``T/3``). An ``a_j`` too small to cover ``|dq_j|`` in
            ``T`` is raised to the triangle's ``4 |dq_j| / T^2``: check ``peaks()`` against limits.
    """

    method = "trapezoidal"

    def __init__(
        self, q0: np.ndarray, q1: np.ndarray, duration: float, acceleration: np.ndarray
    ) -> None:
        T = self.duration = float(duration)
        dist = np.abs(q1 - q0)
        acc = np.where(np.isfinite(acceleration), acceleration, 4.5 * dist / T**2)
        acc = np.where(dist > 0.0, np.maximum(acc, 4.0 * dist / T**2), 0.0)
        ratio = np.divide(dist, acc, out=np.zeros_like(dist), where=acc > 0.0)
        root = np.sqrt(np.maximum(T**2 - 4.0 * ratio, 0.0))
        self.cruise = 2.0 * dist / (T + root)
        self.ramp = np.divide(self.cruise, acc, out=np.zeros_like(dist), where=acc > 0.0)
        self.acceleration = acc
        self.q0, self.q1, self.sign = q0, q1, np.sign(q1 - q0)
        zero = np.zeros_like(q0)
        self._start, self._goal = (q0, zero), (q1, zero)

    def _evaluate(self, t: np.ndarray, order: int) -> np.ndarray:
        T, ta, v, a, sg = self.duration, self.ramp, self.cruise, self.acceleration, self.sign
        tt = np.clip(t, 0.0, T)[:, None]
        rising, falling = tt < ta, tt >= T - ta
        if order == 0:
            up = self.q0 + sg * 0.5 * a * tt**2
            cruise = self.q0 + sg * (0.5 * a * ta**2 + v * (tt - ta))
            down = self.q1 - sg * 0.5 * a * (T - tt) ** 2
        elif order == 1:
            up, cruise, down = sg * a * tt, sg * v + 0.0 * tt, sg * a * (T - tt)
        else:
            up, cruise, down = sg * a + 0.0 * tt, 0.0 * tt + 0.0 * sg, -sg * a + 0.0 * tt
        return np.where(rising, up, np.where(falling, down, cruise))

    def peaks(self) -> Peaks:
        """Cruise speed, acceleration and zero jerk (the acceleration steps between the phases are
        not counted) of each joint, each ``(dof,)``."""
        return Peaks(self.cruise.copy(), self.acceleration.copy(), np.zeros_like(self.cruise))

    def switch_times(self) -> np.ndarray:
        """The ramps' ends [s], where the accelerations step."""
        T, ramp = self.duration, self.ramp[self.ramp > 0.0]
        times = np.unique(np.concatenate([ramp, T - ramp]))
        return times[(times > 0.0) & (times < T)]


class Trapezoidal(DurationProfileKind):
    """Synchronized trapezoid: the slowest joint's time-optimal duration sets everyone's."""

    name = "trapezoidal"
    needs = "acceleration"

    def build(
        self, motion: PointToPoint, duration: float | np.ndarray, max_acceleration: np.ndarray
    ) -> TrapezoidalProfile:
        return TrapezoidalProfile(
            motion.start.positions, motion.goal.positions, float(duration), max_acceleration
        )

    def _shortest(self, motion: PointToPoint, limits: JointLimits) -> float:
        return durations.trapezoidal_duration(motion.distance, *limits.maxima(motion.dof))

    def warnings(self, motion: PointToPoint) -> tuple[str, ...]:
        return (STEP_WARNING, *super().warnings(motion))
