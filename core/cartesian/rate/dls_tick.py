"""One tick of ``resolved_rate_dls``: damping, the path clock, the rate bounds, the QP, the step.

``DlsTick.step`` does, from the state at tick ``k`` (``core.cartesian.rate.control`` runs it):

1. ``sigma_min`` of the task Jacobian and ``lambda = damping(sigma_min)`` (at least
   ``REDUNDANCY_DAMPING`` for a redundant arm, so the step is the minimum-norm one).
2. The path clock's rate ``kappa <= 1``: the largest that keeps the DLS rates of the feedforward
   twist within ``TIME_SCALE_MARGIN`` of the velocity limits (online time scaling, Dahl & Nielsen,
   IEEE Trans. Robot. Autom. 6(5), 1990), skipped where a norm bound, then a Cholesky solve, show it
   is 1.
3. The rate bounds (``rate_bounds``): velocity limits, the previous tick's rates +- ``a_max dt``
   (the rates start at rest) and the braking bound that keeps every joint able to stop before its
   position limits (less ``margin``); the braking bound is skipped over the ticks ``clear_ticks``
   shows no joint at full speed can come within its stopping distance of a limit.
4. The QP ``min ||J qd - V||^2 + lambda^2 ||qd||^2`` within the bounds (and the extra rows: obstacle
   avoidance) for ``V = kappa s' unit_twist + K e`` on one warm-started OSQP workspace (any other
   qpsolvers backend through ``solve_dls_qp``), then the tool speed cap (``speed_scale``).
5. ``q + qd dt``, clipped into the position limits (skipped on clear ticks).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from core.cartesian.rate.qp import (
    BRAKING_SHARE,
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
from core.cartesian.task import CartesianTask
from core.errors import PlanningError
from core.trajectory import DEFAULT_SAMPLE_PERIOD

LOOK_AHEAD = 2.0 ** np.arange(11)
"""Clear spans [ticks] ``_look_ahead`` tries (1 to 1024)."""
RECHECK = 16
"""Ticks between looks for the clear span (``clear_ticks``) while a joint is near a position limit."""


class DlsTick:
    """The ``resolved_rate_dls`` controller of one run (a ``TickController``).

    Args:
        log: The run's arrays (rates, positions, bounds and the figures are written there).
        limits: Joint position, velocity and acceleration limits.
        rows: Task rows of the Jacobian (``task_rows``).
        dt: Control period [s].
        gain: Feedback gain K [1/s].
        twist_bound: ``max |unit twist| / min v_max`` along the path (with room for rounding):
            with it a norm bound tells when the feedforward cannot reach the velocity limits.
        solver: qpsolvers name (``osqp``: the per-tick workspace).
        extra_rows: Extra inequality rows per tick (OSQP only), or None.
        caps: Tool speed limits (linear rows, linear [m/s], angular [rad/s]); ``inf``: none.
        margin: ``(dof,)`` [rad or m] kept from each position limit (room for the smoothing of
            ``core.cartesian.rate.output``).
        box_acceleration: Bound the rates by the previous ones +- ``a_max dt`` (False with
            ``allow_violations``: the client accepts accelerations over the limits).
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
        margin: np.ndarray,
        box_acceleration: bool = True,
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
        if limits.acceleration is None:
            raise ValueError("the DLS tick needs acceleration limits")
        self.margin, self.rest, self.boxed = margin, np.zeros(dof), box_acceleration
        step_a = limits.acceleration * dt
        self.steps = np.stack([-step_a, step_a])  # the acceleration box about the previous rates
        # braking_bounds in place: room [q - lo', hi' - q] = sign q + edge, then
        # sqrt(2 b room + (b dt)^2) - b dt, signed back (-, +)
        b = BRAKING_SHARE * limits.acceleration
        self.sign, self.edge = (
            np.array([[1.0], [-1.0]]),
            np.stack([-(self.lo_q + margin), self.hi_q - margin]),
        )
        self.two_b, self.bdt = 2.0 * b, b * dt
        self.bdt2, self.room = self.bdt * self.bdt, np.empty((2, dof))
        # within a stopping distance (and a tick at full speed) of these, braking binds
        stop = self.vmax * self.vmax / (2.0 * b) + self.vmax * dt
        self.reach = np.stack([self.lo_q + margin + stop, self.hi_q - margin - stop])
        log.bounds[:, 0], log.bounds[:, 1] = -self.vmax, self.vmax  # (unboxed, clear ticks)
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
            rows = () if self.extra_rows is None else _within(self.extra_rows(q), B)
            log.iterations[k], fell_back, _ = self.qp.solve(J, V, lam, B[0], B[1], out, rows)
            log.solve_time[k] = time.perf_counter() - start
        else:
            problem = build_dls_qp(J, V, lam, q, self.limits, dt, (B[0], B[1]))
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
            if c < 1.0:  # (then back into the acceleration box: the joints' limits come first)
                out *= c
                np.maximum(out, B[0], out=out)
                np.minimum(out, B[1], out=out)
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
        """The rate bounds of tick ``k`` (``rate_bounds(q, limits, dt, rates[k - 1], margin)``,
        without the previous rates when not boxed), written in place into ``log.bounds[k]``, and
        whether the tick is clear (the braking bound cannot bind: skipped, and the next
        positions need no clipping)."""
        log, B = self.log, self.log.bounds[k]
        clear = k < self.clear_until
        if self.boxed:
            np.add(log.rates[k - 1] if k else self.rest, self.steps, out=B)
            np.maximum(B, self.low_v, out=B)
            np.minimum(B, self.vmax, out=B)
        elif not clear:
            B[0], B[1] = self.low_v, self.vmax
        if not clear:
            if k >= self.recheck:
                self._look_ahead(k, q)
            room = self.room  # braking_bounds(q, limits, dt, margin), in place
            np.multiply(self.sign, q, out=room)
            np.add(room, self.edge, out=room)
            np.maximum(room, 0.0, out=room)
            np.multiply(room, self.two_b, out=room)
            np.add(room, self.bdt2, out=room)
            np.sqrt(room, out=room)
            np.subtract(room, self.bdt, out=room)  # (-brake_lo, brake_hi)
            np.maximum(B[0], np.negative(room[0], out=room[0]), out=B[0])
            np.minimum(B[1], room[1], out=B[1])
            np.minimum(B[0], B[1], out=B[0])  # (never empty but by rounding: upper wins)
        return B, clear

    def held_box(self) -> np.ndarray:
        """``(2, dof)``: where a joint counts as held at a position limit (the limits less the
        margin the braking bound keeps, and 1e-9 for rounding)."""
        slack = 1e-9
        return np.stack([self.lo_q + self.margin + slack, self.hi_q - self.margin - slack])

    def _look_ahead(self, k: int, q: np.ndarray) -> None:
        """Every ``RECHECK`` ticks near a limit: the ticks after ``k`` whose braking bound cannot
        bind (``clear_until``). Boxed, a joint's rate after ``m`` more ticks is at most ``v_m =
        min(v_max, |qd_prev| + (m + 1) a_max dt)``: while its room to the limit (less the margin)
        covers ``m`` ticks at ``v_m`` and the braking distance from ``v_m``, ``v_m dt + v_m^2 /
        (2 b)``, its braking bound stays above any rate it may have (and the next positions inside
        the limits): the largest such ``m`` among ``LOOK_AHEAD`` for every joint. Unboxed, rates
        may reach ``v_max`` at once (``clear_ticks`` on the full stopping distance)."""
        n = len(self.log.s)
        if not self.boxed:
            span = clear_ticks((self.reach - q) / self.dt, self.vmax, n)
        else:
            speed = np.abs(self.log.rates[k - 1]) if k else self.rest
            room = np.minimum(q + self.edge[0], self.edge[1] - q)  # (edge: -lo', hi')
            v = np.minimum(self.vmax, speed + (LOOK_AHEAD[:, None] + 1.0) * self.steps[1])
            need = (LOOK_AHEAD[:, None] + 1.0) * self.dt * v + v * v / self.two_b
            fits = np.flatnonzero((need <= room).all(axis=1))
            span = int(LOOK_AHEAD[fits[-1]]) if fits.size else 0
        self.clear_until = k + 1 + min(span, n)
        self.recheck = self.clear_until if self.clear_until > k + 1 else k + RECHECK


def _within(
    rows: Sequence[tuple[np.ndarray, float]], B: np.ndarray
) -> Sequence[tuple[np.ndarray, float]]:
    """``rows`` (``a . qd >= b``) with each ``b`` lowered to at most the largest ``a . qd`` the rate
    bounds ``B`` (2, dof) allow, so no row alone empties the QP: a velocity damper asking for more
    than this tick's accelerations can give is met as far as they can (the continuous collision
    check of the returned motion has the last word)."""
    if not rows:
        return rows
    out = []
    for a, b in rows:
        best = float(np.where(a > 0.0, a * B[1], a * B[0]).sum())
        out.append((a, min(b, best - 1e-12 * (1.0 + abs(best)))))
    return out


def smoothing_margin(task: CartesianTask, limits: RateLimits, duration: float) -> np.ndarray:
    """[rad or m] (dof,): room the DLS keeps from each position limit for the returned motion,
    which smooths the controller's over about one returned interval h (``core.cartesian.rate.smooth``:
    positions within ``h^2/8`` of the change of acceleration of the controller's), where a joint
    brakes to a stop at a limit (at ``BRAKING_SHARE a_max``): ``BRAKING_SHARE a_max h^2 / 4``,
    at most a tenth of the joint's range. ``h``: ``sample_period`` (default 0.01 s), or the
    nominal ``duration`` [s] over ``samples - 1``."""
    if task.samples is not None:
        h = duration / max(int(task.samples) - 1, 1)
    else:
        h = DEFAULT_SAMPLE_PERIOD if task.sample_period is None else float(task.sample_period)
    acceleration = np.asarray(task.robot.acceleration_limits, dtype=float)
    span = limits.position[:, 1] - limits.position[:, 0]
    return np.minimum(BRAKING_SHARE * acceleration * h * h / 4.0, 0.1 * span)
