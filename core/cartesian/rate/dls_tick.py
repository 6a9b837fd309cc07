"""One tick of ``resolved_rate_dls``: damping, the path clock, the rate bounds, the QP, the step.

``DlsTick.step`` does, from the state at tick ``k`` (``core.cartesian.rate.control`` runs it):

1. ``sigma_min`` of the task Jacobian and ``lambda = damping(sigma_min)`` (at least
   ``REDUNDANCY_DAMPING`` for a redundant arm, so the step is the minimum-norm one).
2. The path clock's rate ``kappa <= 1``: the largest that keeps the DLS rates of the feedforward
   twist within ``TIME_SCALE_MARGIN`` of the velocity limits (online time scaling, Dahl & Nielsen,
   IEEE Trans. Robot. Autom. 6(5), 1990), skipped where a norm bound, then a Cholesky solve, show it
   is 1.
3. The rate bounds (``rate_bounds``): velocity limits and ``(q_min - q)/dt <= qd <= (q_max -
   q)/dt``; left at the velocity limits over the ticks ``clear_ticks`` shows no position limit can
   reach.
4. The QP ``min ||J qd - V||^2 + lambda^2 ||qd||^2`` within the bounds (and the extra rows: obstacle
   avoidance) for ``V = kappa s' unit_twist + K e`` on one warm-started OSQP workspace (any other
   qpsolvers backend through ``solve_dls_qp``), then the tool speed cap (``speed_scale``).
5. ``q + qd dt``, clipped into the position limits (skipped on clear ticks).
"""

from __future__ import annotations

import math
import time

import numpy as np

from core.cartesian.rate.qp import (
    REDUNDANCY_DAMPING,
    SINGULAR_REGION,
    RateLimits,
    build_dls_qp,
    damping,
    solve_dls_qp,
)
from core.cartesian.rate.steps import (
    TIME_SCALE_MARGIN,
    clear_ticks,
    feedforward_ratio,
    singular_values,
    smallest_singular_value,
    speed_scale,
    svd,
    time_scale,
)
from core.cartesian.rate.tick_qp import DlsQpSolver, ExtraRows
from core.cartesian.rate.ticks import TickLog
from core.errors import PlanningError

RECHECK = 16
"""Ticks between looks for the clear span (``clear_ticks``) while a joint is near a position limit."""


class DlsTick:
    """The ``resolved_rate_dls`` controller of one run (a ``TickController``).

    Args:
        log: The run's arrays (rates, positions, bounds and the figures are written there).
        limits: Joint position and velocity limits.
        rows: Task rows of the Jacobian (``task_rows``).
        dt: Control period [s].
        gain: Feedback gain K [1/s].
        twist_bound: ``max |unit twist| / min v_max`` along the path (with room for rounding):
            with it a norm bound tells when the feedforward cannot reach the velocity limits.
        solver: qpsolvers name (``osqp``: the per-tick workspace).
        extra_rows: Extra inequality rows per tick (OSQP only), or None.
        caps: Tool speed limits (linear rows, linear [m/s], angular [rad/s]); ``inf``: none.
    """

    def __init__(
        self,
        log: TickLog,
        limits: RateLimits,
        rows: np.ndarray,
        dt: float,
        gain: float,
        twist_bound: float,
        solver: str,
        extra_rows: ExtraRows | None,
        caps: tuple[int, float, float],
    ) -> None:
        dof = limits.velocity.shape[0]
        self.log, self.limits, self.dt, self.gain = log, limits, dt, gain
        self.rows, self.all_rows, self.wide = rows, len(rows) == 6, len(rows) <= dof
        self.twist_bound, self.solver, self.extra_rows = twist_bound, solver, extra_rows
        self.caps, self.capped = caps, caps[1] < math.inf or caps[2] < math.inf
        capacity = 0 if extra_rows is None else int(extra_rows.capacity)
        self.qp = DlsQpSolver(dof, extra_rows=capacity) if solver == "osqp" else None
        self.floor = REDUNDANCY_DAMPING if dof > len(rows) else 0.0
        self.lo_q, self.hi_q = limits.position[:, 0], limits.position[:, 1]
        self.vmax, self.low_v = limits.velocity, -limits.velocity
        self.box = np.stack([self.lo_q, self.hi_q])
        log.bounds[:, 0], log.bounds[:, 1] = -self.vmax, self.vmax  # while no limit is in reach
        self.shift_lam = 0.0
        self.shift: np.ndarray | None = None  # lam^2 I, kept while lam is (the Panda's floor)
        self.clear_until, self.recheck = 0, 0  # ticks k < clear_until: bounds (-v_max, v_max)
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
        """Rates and next positions of tick ``k`` (see the module docstring); returns ``kappa``."""
        log, dt = self.log, self.dt
        J = J_now if self.all_rows else J_now[self.rows]
        kappa, lam = self._clock_rate(k, J, sd, unit_twist)
        B, clear = self._bounds(k, q)
        V = np.array(
            [kappa * (sd * u) + self.gain * x for u, x in zip(units, e_task, strict=False)]
        )
        out = log.rates[k]
        start = time.perf_counter()
        if self.qp is not None:
            rows = () if self.extra_rows is None else self.extra_rows(q)
            log.iterations[k], fell_back, _ = self.qp.solve(J, V, lam, B[0], B[1], out, rows)
            log.solve_time[k] = time.perf_counter() - start
        else:
            problem = build_dls_qp(J, V, lam, q, self.limits, dt)
            one = solve_dls_qp(problem, self.solver)
            out[:] = one.x
            log.iterations[k], log.solve_time[k], fell_back = (
                one.iterations,
                one.solve_time,
                one.fallback,
            )
        self.fallbacks += fell_back
        if self.capped:  # the tool's speed limits hold for the feedback term too
            c = speed_scale(J_now, out, *self.caps)
            if c < 1.0:
                out *= c
        nxt = log.positions[k + 1]
        np.multiply(out, dt, out=nxt)
        np.add(q, nxt, out=nxt)
        if not clear:  # (a clear tick's q + qd dt is more than v_max dt inside the limits)
            np.maximum(nxt, self.lo_q, out=nxt)
            np.minimum(nxt, self.hi_q, out=nxt)
        return kappa

    def _clock_rate(
        self, k: int, J: np.ndarray, sd: float, unit_twist: np.ndarray
    ) -> tuple[float, float]:
        """The path clock's rate and ``lambda`` for tick ``k`` (both logged, with ``sigma_min``)."""
        log = self.log
        gram = J.dot(J.T)
        if self.wide:
            sigma_min = smallest_singular_value(J, gram, 2.0 * SINGULAR_REGION)
        else:
            sigma_min = float(singular_values(J)[-1])
        log.sigma[k] = sigma_min
        log.damping[k] = lam = damping(sigma_min, floor=self.floor)
        gains = 1.0 / sigma_min if sigma_min > 0.0 else math.inf
        if lam > 0.0:
            gains = min(gains, 0.5 / lam)
        kappa = 1.0
        # |qd_ff|_inf <= |twist| max_i S_i / (S_i^2 + lam^2) / min v_max: the norm bound may bind
        if abs(sd) * gains * self.twist_bound > TIME_SCALE_MARGIN:
            twist = sd * unit_twist
            # Cholesky first: the SVD route (exactly as before) only where it may bind.
            if lam != self.shift_lam:
                self.shift_lam = lam
                self.shift = lam * lam * np.eye(len(self.rows)) if lam else None
            ratio = feedforward_ratio(J, gram, self.shift, twist, self.vmax)
            if ratio > TIME_SCALE_MARGIN * (1.0 - 1e-9):
                log.time_scale[k] = kappa = time_scale(*svd(J), twist, lam, self.vmax)
        return kappa, lam

    def _bounds(self, k: int, q: np.ndarray) -> tuple[np.ndarray, bool]:
        """The rate bounds of tick ``k`` (``rate_bounds(q, limits, dt)``, written in place into
        ``log.bounds[k]`` as they stand while clear) and whether the tick is clear."""
        B = self.log.bounds[k]
        clear = k < self.clear_until
        if not clear:
            np.subtract(self.box, q, out=B)
            np.divide(B, self.dt, out=B)
            if k >= self.recheck:
                self.clear_until = k + 1 + clear_ticks(B, self.vmax, len(self.log.s))
                self.recheck = self.clear_until if self.clear_until > k + 1 else k + RECHECK
            np.maximum(B, self.low_v, out=B)
            np.minimum(B, self.vmax, out=B)
        return B, clear
