"""A PTP between stops timed by a joint profile, synchronously: on the straight joint segment.

An industrial PTP moves every joint by the same normalized profile: q(t) = q0 + s(t) (q1 - q0)
with s from 0 to 1, so the joint path is the straight segment the program's geometry assumes
(segment ``s``, blends, the collision check's ``s``). The law s(t) is the time-optimal one of the
requested kind (``trapezoidal``, ``quintic``, ``jerk_limited`` of ``core.joint.profiles``) for one
coordinate from 0 to 1 under the tightest of the joints' limits per unit s::

    v_s = min_j v_j / |dq_j|,   a_s = min_j a_j / |dq_j|,   j_s = min_j jerk_j / |dq_j|

(over the joints that move; ``v_j``, ``a_j`` scaled by the segment's ``velocity_scale`` and
``acceleration_scale``, the jerk limits unscaled). |dq_j| s' <= v_j for every j is exactly
s' <= v_s (and so on), so the straight motion holds every joint's limits and is the fastest that
does. The peaks are the law's times |dq_j|, exact. Units: [rad or m], [s].
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.joint.motion import PointToPoint
from core.joint.point_to_point import plan_joint
from core.limits import JointLimits
from core.trajectory import Peaks, Profile

__all__ = ["StraightProfile", "straight_ptp"]

S_NAME = ("s",)
"""The law's one coordinate (named in its rare errors, e.g. Ruckig's duration cap)."""


class StraightProfile:
    """q(t) = q0 + s(t) (q1 - q0): a one-coordinate profile ``law`` (s from 0 to 1) along the
    joint segment, exactly ``q0`` and ``q1`` where s is exactly 0 and 1.

    Args:
        q0, q1: Start and goal joint positions ``(dof,)``.
        law: A ``core.trajectory.Profile`` with one coordinate, rest to rest from 0 to 1.
    """

    def __init__(self, q0: np.ndarray, q1: np.ndarray, law: Profile) -> None:
        self.q0, self.q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
        self.dq = self.q1 - self.q0
        self.law = law
        self.duration = float(law.duration)

    def _positions(self, s: np.ndarray) -> np.ndarray:
        q = self.q0 + s * self.dq
        q[s[:, 0] == 1.0] = self.q1
        return q

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """Derivative ``order`` at times ``t`` ``(N,)`` [s] -> ``(N, dof)``."""
        s = self.law(np.asarray(t, dtype=float), order)
        return self._positions(s) if order == 0 else s * self.dq

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities, accelerations at ``t`` ``(N,)`` [s], each ``(N, dof)``."""
        s, sd, sdd = self.law.sample(np.asarray(t, dtype=float))
        return self._positions(s), sd * self.dq, sdd * self.dq

    def peaks(self) -> Peaks:
        """The law's exact peaks times |q1 - q0| per joint."""
        p, d = self.law.peaks(), np.abs(self.dq)
        return Peaks(p.velocity[0] * d, p.acceleration[0] * d, p.jerk[0] * d)

    def switch_times(self) -> np.ndarray:
        """The law's switch times [s]."""
        return self.law.switch_times()


def straight_ptp(
    kind: str,
    q0: np.ndarray,
    q1: np.ndarray,
    limits: JointLimits,
    deadline: Deadline = NO_DEADLINE,
) -> StraightProfile:
    """The fastest ``kind`` profile along the segment from ``q0`` to ``q1`` (``(dof,)``, distinct)
    within ``limits`` (velocity and acceleration ``(dof,)``, jerk ``(dof,)`` or None): see the
    module docstring. Errors as ``plan_joint``'s (``InputError`` without a needed limit)."""
    dist = np.abs(np.asarray(q1, dtype=float) - np.asarray(q0, dtype=float))
    moving = dist > 0.0

    def per_unit(limit: np.ndarray | None) -> np.ndarray | None:
        if limit is None:
            return None
        return np.array([np.min(np.asarray(limit, dtype=float)[moving] / dist[moving])])

    unit = JointLimits(
        velocity=per_unit(limits.velocity),
        acceleration=per_unit(limits.acceleration),
        jerk=per_unit(limits.jerk),
    )
    plan = plan_joint(
        kind,
        PointToPoint.create([0.0], [1.0]),
        unit,
        samples=2,
        joint_names=S_NAME,
        deadline=deadline,
    )
    return StraightProfile(q0, q1, plan.profile)
