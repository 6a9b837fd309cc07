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
the answer to "the line is blocked", not a solver failure. For an arm without redundancy that
answer comes at once where, to first order, the tolerance band cannot give a point of the line the
clearance it lacks (``_blocked``).

With obstacles each count is a few SQP rounds (clearance rows linearized about the last solution,
``AVOID_ROUNDS`` at most); a count stops at its first round clear of the obstacles (accepted, or too
few knots for the band), and that clear path warm-starts the later counts instead of Taylor's knots,
which ignore the obstacles (issue 25 item 9: the Panda elbow line spent 6 rounds of 100 iterations
at 3 knots and the next count started inside the ball; 870 iterations then, about 350 now).
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
from core.kinematics import SymbolicKinematics, task_rows
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
    if search.blocked:
        warnings = [
            *warnings,
            "the tolerance band cannot keep the clearance where the line passes an obstacle "
            "(first order, this arm has no redundancy); returning Taylor's knots, which ignore "
            "obstacles",
        ]
    elif best is taylor and search.attempts:
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
        self.blocked = False
        """The tolerance band cannot keep the clearance (``_blocked``): no count was tried."""
        self.seed: Knots | None = None
        """The last solution clear of the obstacles (the warm start of later counts), if any."""

    def run(self) -> Knots:
        """Galloping up from 3 knots (x1.5) to the first accepted count, then bisection below it."""
        best, lo, hi = self.taylor, 2, len(self.taylor)
        if self.task.clearance is not None:  # Taylor's knots ignore obstacles: try more knots
            hi = max(hi, AVOID_MIN_KNOTS)
        straight = Knots(np.array([0.0, 1.0]), self.taylor.positions[[0, -1]])
        if hi > 2 and self._within(straight)[0]:  # joint interpolation alone keeps the bound
            self.attempts.append(
                {"knots": 2, "status": "no_variables", "iterations": 0, "solve_time_s": 0.0,
                 "accepted": True}
            )  # fmt: skip
            return straight
        if self.task.clearance is not None and _blocked(self.task, self.taylor):
            self.blocked = True
            return best  # (Taylor's knots: the collision check names the contact)
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
        start, rows = KnotPath(self.seed or best)(s), None
        rounds = iterations = 0
        solve_time = 0.0
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
            iterations, solve_time = iterations + sol.iterations, solve_time + sol.solve_time
            knots = Knots(s, sol.positions)
            ok, clear = self._within(knots)  # IPOPT's optimality is not needed, feasibility is
            if clear and task.clearance is not None:
                self.seed = knots  # clear of the obstacles: the warm start of later counts
            # clear but off the tolerance band: this count is too few (more rounds about a clear
            # path do not help: measured on the Panda elbow line, 3 more rounds of 100 iterations
            # for nothing; a later count starts from this clear path)
            if ok or clear or sol.status in TIME_STATUSES or task.deadline.expired():
                break
            start = sol.positions
        self.attempts.append(
            {
                "knots": count,
                "status": sol.status,
                "iterations": iterations,  # (every SQP round's)
                "solve_time_s": solve_time,
                "accepted": ok,
                **({"clearance_rounds": rounds} if task.clearance is not None else {}),
            }
        )
        if sol.status in TIME_STATUSES and task.deadline.expired():
            task.deadline.check("bounded deviation NLP")
        return (knots if ok else None), sol.status

    def _within(self, knots: Knots) -> tuple[bool, bool]:
        """Whether the spline through ``knots`` stays within ``ACCEPT`` of the tolerances, the
        limits and the clearance (accepted), and whether it keeps the clearance (with obstacles)."""
        task, kin = self.task, self.task.robot
        path = KnotPath(knots)
        s = dense_times(knots.s, PATH_CHECKS)
        dev = path_deviation(
            kin, self.line, path, s, task.position_tolerance, task.orientation_tolerance
        )
        q = path(s)
        clear = task.clearance is not None and clearance_ok(task.clearance, q, CLEARANCE_MARGIN / 4)
        ok = bool(
            dev.position.max() <= ACCEPT * task.position_tolerance
            and dev.orientation.max() <= ACCEPT * task.orientation_tolerance
            and bool(inside(q, kin.position_limits).all())
            and (task.clearance is None or clear)
        )
        return ok, clear


BLOCKED_FACTOR = 2.0
"""``_blocked``: the clearance a point of the line lacks must exceed this many times what the
tolerance band can give it (first order) for the line to count as blocked."""


def _blocked(task: CartesianTask, taylor: Knots) -> bool:
    """Whether no knot set can keep the clearance within the tolerance band, by first order: an arm
    without redundancy (as many joints as task rows) has one configuration per tool pose near a
    solution, so at a point of the line a pair's distance ``d`` changes by ``g . dq = (J^-T g) .
    dX`` for a tool displacement ``dX`` within the band (``|dX_p| <= tol_p``, ``|dX_o| <= tol_o``):
    at most ``|w_p| tol_p + |w_o| tol_o`` with ``w = J^-T g``. Where a pair along Taylor's path
    (on the line) lacks more than ``BLOCKED_FACTOR`` times that, every count would only spend
    IPOPT's iterations (measured: the UR5 line through a 3 cm ball, 18 solves and 7.5 CPU-s before
    returning Taylor's knots). Redundant arms move in the null space: never blocked here."""
    clearance, robot = task.clearance, task.robot
    rows = task_rows(robot.task_space)
    if clearance is None or robot.dof != len(rows):
        return False
    qs = KnotPath(taylor)(dense_times(taylor.s, PATH_CHECKS))
    deficit = clearance.threshold[None, :] - clearance.distances(qs)
    linear = rows < 3
    for j in np.flatnonzero((deficit > 0.0).any(axis=1)):
        pairs, _, n, Jp = clearance.close_pairs(qs[j], float(clearance.threshold.max()))
        if not len(pairs):
            continue
        g = np.einsum("pi,pij->pj", n, Jp)  # (m, dof): gradients of the pairs' distances
        try:
            w = np.linalg.solve(robot.jacobian(qs[j])[rows].T, g.T).T  # (m, rows)
        except np.linalg.LinAlgError:
            continue  # (a singular point: no first-order bound)
        reach = np.linalg.norm(w[:, linear], axis=1) * task.position_tolerance
        reach += np.linalg.norm(w[:, ~linear], axis=1) * task.orientation_tolerance
        if np.any(deficit[j, pairs] > BLOCKED_FACTOR * reach):
            return True
    return False
