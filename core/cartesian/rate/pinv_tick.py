"""One tick of ``resolved_rate``: the pseudo-inverse step (the course notes' sec. 7.2).

``PinvTick.step`` solves ``J^-1 V`` (square) or the least-squares ``J^+ V`` for ``V = s'
unit_twist + K e`` from the thin SVD of the task Jacobian, and refuses to step where the smallest
singular value is below ``PINV_SINGULAR_THRESHOLD`` (``Singularity``), where a rate exceeds its
limit (``JointRateLimit``, the notes' warning) or where the step would leave the position limits
(``JointLimit``), each with ``s`` (``core.cartesian.rate.steps.pinv_step``). The path clock keeps
rate 1: it is the classic reference. Then the tool speed cap (``speed_scale``) and ``q + qd dt``.
"""

from __future__ import annotations

import math

import numpy as np

from core.cartesian.rate.qp import RateLimits
from core.cartesian.rate.steps import pinv_step, speed_scale, svd
from core.cartesian.rate.ticks import TickLog
from core.errors import PlanningError
from core.kinematics import Kinematics


class PinvTick:
    """The ``resolved_rate`` controller of one run (a ``TickController``).

    Args:
        robot: The arm (its joint names go into errors).
        log: The run's arrays.
        limits: Joint position and velocity limits.
        rows: Task rows of the Jacobian (``task_rows``).
        dt: Control period [s].
        gain: Feedback gain K [1/s].
        caps: Tool speed limits (linear rows, linear [m/s], angular [rad/s]); ``inf``: none.
    """

    def __init__(
        self,
        robot: Kinematics,
        log: TickLog,
        limits: RateLimits,
        rows: np.ndarray,
        dt: float,
        gain: float,
        caps: tuple[int, float, float],
    ) -> None:
        self.robot, self.log, self.limits, self.dt, self.gain = robot, log, limits, dt, gain
        self.rows, self.all_rows = rows, len(rows) == 6
        self.caps, self.capped = caps, caps[1] < math.inf or caps[2] < math.inf
        self.failure: PlanningError | None = None
        self.fallbacks = 0

    def step(
        self,
        k: int,
        q: np.ndarray,
        J_now: np.ndarray,
        e_task: list[float],
        s: float,
        sd: float,
        unit_twist: np.ndarray,
        units: list[float],
    ) -> float:
        """Rates and next positions of tick ``k``; returns 1 (or 0 with ``failure`` set)."""
        log, dt = self.log, self.dt
        J = J_now if self.all_rows else J_now[self.rows]
        U, S, Vt = svd(J)
        log.sigma[k] = S[-1]
        V = np.array([sd * u + self.gain * x for u, x in zip(units, e_task, strict=False)])
        self.failure, qd = pinv_step(self.robot, U, S, Vt, V, s, q, dt, self.limits)
        if self.failure is not None or qd is None:
            return 0.0
        if self.capped:
            qd = qd * speed_scale(J_now, qd, *self.caps)
        log.rates[k] = qd
        nxt = log.positions[k + 1]
        np.multiply(qd, dt, out=nxt)
        np.add(q, nxt, out=nxt)
        return 1.0
