"""What one resolved-rate run records, tick by tick: ``TickLog`` (arrays preallocated for the run
and written in place by the loop of ``core.cartesian.rate.control`` and by the controllers of
``core.cartesian.rate.dls_tick`` and ``core.cartesian.rate.pinv_tick``), the ``RateRun`` it becomes,
and the ``TickController`` Protocol both controllers satisfy."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from core.errors import PlanningError

ACTIVE_TOLERANCE = 1e-6
"""[rad/s] A rate this close to its bound counts as an active limit."""


@dataclass(frozen=True)
class RateRun:
    """The simulated control ticks of one run (n ticks, ``k = 0..n-1``; steps ``k = 0..n-2``).

    Attributes:
        dt: Control period [s].
        nominal_ticks: Ticks in the nominal duration (the first tick at or after its end).
        nominal_duration: Duration of the nominal profile s(t) [s].
        positions: Joint positions at each tick ``(n, dof)``.
        rates: Joint rates commanded from each tick on ``(n, dof)``; the last row is zero.
        s: Path parameter of the setpoint at each tick ``(n,)``.
        sigma: Smallest singular value of the task Jacobian at each step ``(n-1,)``.
        damping: lambda at each step ``(n-1,)`` (0 for ``resolved_rate``).
        time_scale: Rate of the path clock at each step ``(n-1,)`` (1: nominal speed).
        active: Whether a rate bound was active at each step ``(n-1,)``.
        iterations: QP iterations at each step ``(n-1,)`` (0 for ``resolved_rate``).
        solve_time: QP update and solve time [s] at each step ``(n-1,)``.
        fallbacks: Steps where OSQP stopped short and the exact bounded least squares took over.
        tracking_position: Distance [m] from the setpoint at each tick ``(n,)``.
        tracking_orientation: Angle [rad] from the setpoint at each tick ``(n,)``.
        failure: Why the run stopped short of the goal, or None.
        timing_warnings: Where the clock was slowed for the joint limits (``retime``).
    """

    dt: float
    nominal_ticks: int
    nominal_duration: float
    positions: np.ndarray
    rates: np.ndarray
    s: np.ndarray
    sigma: np.ndarray
    damping: np.ndarray
    time_scale: np.ndarray
    active: np.ndarray
    iterations: np.ndarray
    solve_time: np.ndarray
    fallbacks: int
    tracking_position: np.ndarray
    tracking_orientation: np.ndarray
    failure: PlanningError | None
    timing_warnings: tuple[str, ...] = ()


class TickLog:
    """Per-tick arrays of one run of at most ``n`` ticks (``k = 0..n-1``; step ``k`` moves the
    arm from tick ``k`` to ``k + 1``). Units as ``core.cartesian.rate.control.RateRun``.

    Attributes:
        positions: Joint positions at each tick ``(n, dof)``.
        rates: Joint rates commanded from each tick on ``(n, dof)``.
        s: Path parameter of the setpoint at each tick ``(n,)``.
        sigma, damping, time_scale: Smallest singular value, lambda and path-clock rate per step.
        iterations, solve_time: QP iterations and wall time [s] per step.
        tracking_position, tracking_orientation: Distance [m] and angle [rad] from the setpoint.
        bounds: ``(n, 2, dof)`` lower and upper rate bounds of each step (DLS), else ``(0, 2, dof)``.
    """

    def __init__(self, n: int, dof: int, with_bounds: bool) -> None:
        self.positions, self.rates = np.zeros((n, dof)), np.zeros((n, dof))
        self.s, self.sigma, self.damping = np.zeros(n), np.zeros(n), np.zeros(n)
        self.time_scale = np.ones(n)
        self.iterations, self.solve_time = np.zeros(n, dtype=np.int64), np.zeros(n)
        self.tracking_position, self.tracking_orientation = np.zeros(n), np.zeros(n)
        self.bounds = np.empty((n if with_bounds else 0, 2, dof))

    def run(
        self,
        n: int,
        dt: float,
        nominal: int,
        nominal_duration: float,
        fallbacks: int,
        failure: PlanningError | None,
        dls: bool,
    ) -> RateRun:
        """The ``RateRun`` of the first ``n`` ticks; a step counts as active where a rate is
        within ``ACTIVE_TOLERANCE`` of its bound (DLS)."""
        steps = n - 1
        active: np.ndarray = np.zeros(steps, dtype=bool)
        if dls:
            R, B = self.rates[:steps], self.bounds[:steps]
            near = (R <= B[:, 0] + ACTIVE_TOLERANCE) | (R >= B[:, 1] - ACTIVE_TOLERANCE)
            active = np.asarray(near.any(axis=1))
        return RateRun(
            dt=dt,
            nominal_ticks=nominal,
            nominal_duration=nominal_duration,
            positions=self.positions[:n],
            rates=self.rates[:n],
            s=self.s[:n],
            sigma=self.sigma[:steps],
            damping=self.damping[:steps],
            time_scale=self.time_scale[:steps],
            active=active,
            iterations=self.iterations[:steps],
            solve_time=self.solve_time[:steps],
            fallbacks=int(fallbacks),
            tracking_position=self.tracking_position[:n],
            tracking_orientation=self.tracking_orientation[:n],
            failure=failure,
        )


class TickController(Protocol):
    """One controller's step of a tick: from the state at tick ``k`` it writes the rates
    ``log.rates[k]`` and the next positions ``log.positions[k + 1]`` (and its own figures into
    the log) and returns the path-clock rate ``kappa`` in (0, 1] it ran the tick at, or sets
    ``failure`` (a planning error that ends the run at tick ``k``) and returns 0."""

    failure: PlanningError | None
    fallbacks: int

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
    ) -> float: ...
