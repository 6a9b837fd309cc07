"""What one resolved-rate run records, tick by tick: ``TickLog`` (arrays preallocated for the run
and written in place by the loop of ``core.cartesian.rate.control`` and by the controllers of
``core.cartesian.rate.dls_tick`` and ``core.cartesian.rate.pinv_tick``), and the ``TickController``
Protocol both controllers satisfy."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from core.errors import PlanningError


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
