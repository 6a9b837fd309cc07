"""Bounded deviation as constraints (``bounded_deviation_nlp``): the knot-count search.

Knot-count search: Taylor's knots (after the dense measurement of the trajectory they give) are
feasible with K_T knots. First the straight joint path (2 knots) is checked; then counts from 3
upward (3, 5, 8, 12, ...: x1.5) until one is accepted, then bisection below it. Each solve is
warm-started from the best path known (the spline through the best knots so far, resampled at the new
s_k); the s_k follow the density of Taylor's knots (their quantiles). A solution is accepted when a
numpy check of the spline, denser than the NLP's checks, finds it within ``ACCEPT`` of the
tolerances and inside the joint limits, whatever IPOPT's status (feasibility is what counts, not
optimality of the smoothness). The winner goes through the same timing, dense measurement of the
returned trajectory and splitting as Taylor's (``core.cartesian.knots.finish_knots``).

Failures: when no count below K_T is accepted, ``TimeBudgetExceeded`` if a wall-time cap (or
``task.deadline``) stopped the search, ``NoConvergence`` if a solve stopped at the iteration cap;
otherwise (IPOPT found each smaller count infeasible, or its solution failed the numpy check)
Taylor's knots are returned, with a warning. With obstacles (``task.clearance``) a search that
finds no knot set keeping the clearance within the tolerance band returns Taylor's knots too (they
ignore obstacles), iteration cap or not: the continuous collision check of the returned trajectory
then reports the contact (422 ``collision`` at the same ``s`` as ``bounded_deviation``), which is
the answer to "the line is blocked", not a solver failure.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any, cast

import numpy as np

from core.cartesian.ik_on_path import goal_configuration
from core.cartesian.knot_nlp import (
    ACCEPT,
    COSTS,
    ITERATION_CAP,
    NLP_CHECKS,
    NLP_MAX_ITER,
    NLP_MAX_WALL_TIME,
    NLP_TOTAL_WALL_TIME,
    SYMBOLIC_LOCK,
    TIME_STATUSES,
    build_knot_nlp,
    check_points,
    deviation_function,
    knot_parameters,
    solve_knot_nlp,
)
from core.cartesian.knot_path import KnotPath, Knots
from core.cartesian.knots import (
    PATH_CHECKS,
    TaylorStats,
    check_knot_path,
    finish_knots,
    measured_knots,
    path_deviation,
)
from core.cartesian.measure import dense_times
from core.cartesian.methods.bounded_deviation import taylor_knots
from core.cartesian.partial import plan_partial
from core.cartesian.task import CartesianResult, CartesianTask
from core.cartesian.validate import validated_line
from core.clearance import CLEARANCE_MARGIN, clearance_ok, linearized_clearance_rows
from core.errors import (
    InputError,
    NoConvergence,
    TimeBudgetExceeded,
)
from core.kinematics import SymbolicKinematics
from core.limits import inside
from core.path.base import Path

AVOID_ROUNDS = 6
"""SQP rounds per knot count when avoiding obstacles (clearance relinearized at each solution)."""
AVOID_MIN_KNOTS = 9
"""With an environment the knot-count search goes up to at least this many knots (Taylor's count
ignores obstacles)."""


def plan_bounded_deviation_nlp(
    task: CartesianTask,
    *,
    checks: int = NLP_CHECKS,
    cost: str = "smoothness",
    max_iter: int = NLP_MAX_ITER,
    max_wall_time: float = NLP_MAX_WALL_TIME,
    total_wall_time: float = NLP_TOTAL_WALL_TIME,
) -> CartesianResult:
    """Bounded deviation with the knots optimized by IPOPT (see the module docstring).

    Args:
        task: The Cartesian task (tolerances, timing, sampling, deadline).
        checks: Interior check points per knot segment, >= 1.
        cost: ``"smoothness"`` (squared second differences of the knots) or ``"length"``.
        max_iter: IPOPT iterations per solve, >= 1.
        max_wall_time: [s] IPOPT wall time per solve, > 0 (also capped by ``task.deadline``).
        total_wall_time: [s] for the whole knot-count search.

    Raises what Taylor's method raises, and ``NoConvergence`` when no solve converged (iteration
    cap), ``TimeBudgetExceeded`` when the wall-time caps or the deadline stopped it. With
    ``task.allow_partial`` a failure located at ``s`` plans the reachable prefix instead.
    """
    if cost not in COSTS:
        raise InputError(f"cost must be one of {', '.join(COSTS)}", field=("cost",))
    if checks < 1 or max_iter < 1 or not max_wall_time > 0 or not total_wall_time > 0:
        raise InputError("checks and max_iter must be >= 1, wall times > 0", field=("solver",))
    options = (checks, cost, max_iter, max_wall_time, total_wall_time)
    return plan_partial(task, lambda t: _plan_nlp(t, *options))


def _plan_nlp(
    task: CartesianTask,
    checks: int,
    cost: str,
    max_iter: int,
    max_wall_time: float,
    total_wall_time: float,
) -> CartesianResult:
    line = validated_line(task)
    started = time.perf_counter()
    kin, deadline = task.robot, task.deadline
    tol_p, tol_o = task.position_tolerance, task.orientation_tolerance
    stats = TaylorStats()
    q_goal, warnings, ref = goal_configuration(kin, line, task.q_start, task.q_goal, deadline)
    taylor = taylor_knots(
        kin, line, task.q_start, q_goal, tol_p, tol_o, deadline=deadline, stats=stats, reference=ref
    )
    midpoint_count = len(taylor)
    taylor = check_knot_path(
        kin, line, taylor, tol_p, tol_o, deadline=deadline, stats=stats, reference=ref
    )
    # Taylor's final knots (what ``bounded_deviation`` returns): the count to beat, the warm start.
    taylor, _ = measured_knots(task, line, taylor, stats=stats, reference=ref)
    stats = replace(stats, resplits=0)
    search = _KnotSearch(task, line, taylor, checks, cost, max_iter, max_wall_time, total_wall_time)
    best = search.run()
    diagnostics: dict[str, Any] = {
        "midpoint_knot_count": midpoint_count,
        "taylor_knot_count": len(taylor),
        "knot_counts_tried": [a["knots"] for a in search.attempts],
        "attempts": search.attempts,
        "ipopt_iterations": sum(a["iterations"] for a in search.attempts),
        "nlp_solve_time_ms": 1e3 * sum(a["solve_time_s"] for a in search.attempts),
        "knot_time_ms": 1e3 * (time.perf_counter() - started),
    }
    if best is taylor and search.attempts:
        warnings = [
            *warnings,
            "the NLP found no knot set smaller than Taylor's; returning those"
            if task.clearance is None
            else "the NLP found no knot set that keeps the clearance within the tolerance; "
            "returning Taylor's knots, which ignore obstacles",
        ]
    return finish_knots(
        task, line, best, stats=stats, diagnostics=diagnostics, warnings=warnings, reference=ref
    )


class _KnotSearch:
    """The smallest accepted knot count between 3 and Taylor's count (see the module docstring)."""

    def __init__(
        self,
        task: CartesianTask,
        line: Path,
        taylor: Knots,
        checks: int,
        cost: str,
        max_iter: int,
        max_wall_time: float,
        total_wall_time: float,
    ) -> None:
        self.task, self.line, self.taylor = task, line, taylor
        self.checks, self.cost, self.max_iter = checks, cost, max_iter
        self.max_wall_time = max_wall_time
        self.end = time.monotonic() + total_wall_time
        with SYMBOLIC_LOCK:
            self.deviation = deviation_function(
                cast(SymbolicKinematics, task.robot).fk_casadi(),
                cast(Any, line),  # a line or an arc (the registry's shapes)
                task.position_tolerance,
                task.orientation_tolerance,
            )
        self.attempts: list[dict[str, Any]] = []

    def run(self) -> Knots:
        """Galloping up from 3 knots (x1.5) to the first accepted count, then bisection below it."""
        best, lo, hi = self.taylor, 2, len(self.taylor)
        if self.task.clearance is not None:  # Taylor's knots ignore obstacles: try more knots
            hi = max(hi, AVOID_MIN_KNOTS)
        straight = Knots(np.array([0.0, 1.0]), self.taylor.positions[[0, -1]])
        if hi > 2 and self._within(straight):  # joint interpolation alone keeps the bound
            self.attempts.append(
                {"knots": 2, "status": "no_variables", "iterations": 0, "solve_time_s": 0.0,
                 "accepted": True}
            )  # fmt: skip
            return straight
        capped = False  # some count failed at the iteration cap (not shown infeasible)
        timed_out = False
        count = 3
        while count < hi and not timed_out:
            found, status = self._try(count, best)
            if found is not None:
                best, hi = found, count
                break
            lo, timed_out = count, status in TIME_STATUSES
            capped = capped or status in ITERATION_CAP
            count = max(count + 1, int(np.ceil(1.5 * count)))
        while hi - lo > 1 and not timed_out:
            count = (lo + hi) // 2
            found, status = self._try(count, best)
            if found is not None:
                best, hi = found, count
            else:
                lo, timed_out = count, status in TIME_STATUSES
                capped = capped or status in ITERATION_CAP
        if best is not self.taylor or len(self.taylor) <= 3:
            return best
        tried = [a["status"] for a in self.attempts]
        if timed_out:
            raise TimeBudgetExceeded(
                "the knot NLP reached its wall-time cap before finding a solution",
                extra={"statuses": tried},
            )
        if capped and self.task.clearance is None:
            raise NoConvergence(
                "IPOPT did not converge for any knot count below Taylor's "
                f"{len(self.taylor)} (iteration cap {self.max_iter})",
                extra={"statuses": tried},
            )
        return best

    def _try(self, count: int, best: Knots) -> tuple[Knots | None, str]:
        task = self.task
        task.deadline.check("bounded deviation NLP")
        # Half the time left at most: the rest is for timing and measuring the result.
        budget = min(
            self.max_wall_time, 0.5 * task.deadline.remaining(), self.end - time.monotonic()
        )
        if budget <= 0.0:
            return None, "Maximum_WallTime_Exceeded"
        s = knot_parameters(count, self.taylor.s)
        start, rows = KnotPath(best)(s), None
        rounds = 0
        for _ in range(AVOID_ROUNDS if task.clearance is not None else 1):
            rounds += 1
            if task.clearance is not None:  # SQP round: clearance linearized about ``start``
                q_checks = KnotPath(Knots(s, start))(check_points(s, self.checks))
                rows = linearized_clearance_rows(task.clearance, q_checks)
            with SYMBOLIC_LOCK:
                problem = build_knot_nlp(
                    self.deviation,
                    task.robot,
                    s,
                    best.positions[0],
                    best.positions[-1],
                    checks=self.checks,
                    cost=self.cost,
                    max_iter=self.max_iter,
                    max_wall_time=budget,
                    clearance_rows=rows,
                )
            sol = solve_knot_nlp(problem, start)
            knots = Knots(s, sol.positions)
            ok = self._within(knots)  # IPOPT's optimality is not needed, feasibility is
            if ok or sol.status in TIME_STATUSES or task.deadline.expired():
                break
            start = sol.positions
        self.attempts.append(
            {
                "knots": count,
                "status": sol.status,
                "iterations": sol.iterations,
                "solve_time_s": sol.solve_time,
                "accepted": ok,
                **({"clearance_rounds": rounds} if task.clearance is not None else {}),
            }
        )
        if sol.status in TIME_STATUSES and task.deadline.expired():
            task.deadline.check("bounded deviation NLP")
        return (knots if ok else None), sol.status

    def _within(self, knots: Knots) -> bool:
        """The spline through ``knots`` stays within ``ACCEPT`` of the tolerances and the limits."""
        task, kin = self.task, self.task.robot
        path = KnotPath(knots)
        s = dense_times(knots.s, PATH_CHECKS)
        dev = path_deviation(
            kin, self.line, path, s, task.position_tolerance, task.orientation_tolerance
        )
        q = path(s)
        return bool(
            dev.position.max() <= ACCEPT * task.position_tolerance
            and dev.orientation.max() <= ACCEPT * task.orientation_tolerance
            and bool(inside(q, kin.position_limits).all())
            and (task.clearance is None or clearance_ok(task.clearance, q, CLEARANCE_MARGIN / 4))
        )
