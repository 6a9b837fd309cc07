"""Taylor's bounded deviation (``bounded_deviation``): knots by the recursive midpoint test, a C2
spline through them, split again wherever the returned trajectory strays (``core.cartesian.knots``).
"""

from __future__ import annotations

import time

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.ik_on_path import goal_configuration, reference_at, solve_on_line, task_error
from core.cartesian.knot_path import Knots
from core.cartesian.knots import (
    MARGIN,
    MAX_DEPTH,
    MAX_KNOTS,
    TaylorStats,
    check_knot_path,
    finish_knots,
)
from core.cartesian.partial import plan_partial
from core.cartesian.task import CartesianResult, CartesianTask
from core.cartesian.validate import validated_line
from core.errors import (
    Infeasible,
)
from core.kinematics import Kinematics
from core.path.base import Path


def taylor_knots(
    kin: Kinematics,
    line: Path,
    q_start: np.ndarray,
    q_goal: np.ndarray,
    position_tolerance: float,
    orientation_tolerance: float,
    *,
    max_depth: int = MAX_DEPTH,
    deadline: Deadline = NO_DEADLINE,
    stats: TaylorStats | None = None,
    reference: Knots | None = None,
) -> Knots:
    """Taylor's recursive midpoint method: knots from ``q_start`` (s=0) to ``q_goal`` (s=1).

    A segment is kept when FK of its joint midpoint is within ``MARGIN`` times the tolerances [m],
    [rad] of the Cartesian midpoint; otherwise it is halved at a knot solved by ``solve_on_line`` from
    the joint midpoint (``reference``, the continuation, gives the branch when the joint midpoint is
    far from it). Past ``max_depth`` halvings (or ``MAX_KNOTS`` knots) ``Infeasible`` is raised
    with the ``s`` of the segment.
    """
    stats = TaylorStats() if stats is None else stats
    tol_p, tol_o = MARGIN * position_tolerance, MARGIN * orientation_tolerance
    found: list[tuple[float, np.ndarray]] = []
    label = kin.configuration(np.asarray(q_start, dtype=float))  # midpoints keep the start's

    def split(sa: float, qa: np.ndarray, sb: float, qb: np.ndarray, depth: int) -> None:
        deadline.check("bounded deviation")
        stats.midpoint_tests += 1
        stats.max_depth = max(stats.max_depth, depth)
        s_mid, q_mid = 0.5 * (sa + sb), 0.5 * (qa + qb)
        T_mid = line.pose(s_mid)
        err_p, err_o = task_error(kin.task_space, kin.fk(q_mid), T_mid)
        if err_p <= tol_p and err_o <= tol_o:
            return
        if depth >= max_depth or len(found) + 2 >= MAX_KNOTS:
            raise Infeasible(
                f"the deviation stays above the tolerance near s={s_mid:.4g} after {depth} "
                f"halvings of the line (limit {max_depth}, {MAX_KNOTS} knots)",
                s=s_mid,
                extra={"depth": depth},
            )
        q_new = solve_on_line(kin, line, s_mid, q_mid, reference_at(reference, s_mid), label=label)
        stats.ik_calls += 1
        split(sa, qa, s_mid, q_new, depth + 1)
        found.append((s_mid, q_new))
        split(s_mid, q_new, sb, qb, depth + 1)

    q_start, q_goal = np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float)
    split(0.0, q_start, 1.0, q_goal, 0)
    s = np.array([0.0, *(f[0] for f in found), 1.0])
    positions = np.vstack([q_start, *(f[1] for f in found), q_goal])
    return Knots(s, positions)


def plan_bounded_deviation(task: CartesianTask) -> CartesianResult:
    """Taylor's bounded deviation: knots by the recursive midpoint test, a C2 spline through them,
    split again wherever the returned trajectory strays (see the section comment above).

    Raises ``InputError`` / ``JointLimit`` (entry checks), ``Unreachable`` / ``JointLimit`` /
    ``BranchFlip`` (a knot's IK, with ``s``), ``Infeasible`` (depth, knot or splitting limits),
    ``JointRateLimit`` (a fixed duration too short), ``Singularity`` (joint rates),
    ``TimeBudgetExceeded`` (``task.deadline``). With ``task.allow_partial`` a failure located at
    ``s`` gives the plan of the reachable prefix instead (``plan_partial``).
    """
    return plan_partial(task, _plan_taylor)


def _plan_taylor(task: CartesianTask) -> CartesianResult:

    line = validated_line(task)
    started = time.perf_counter()
    stats = TaylorStats()
    q_goal, warnings, reference = goal_configuration(
        task.robot, line, task.q_start, task.q_goal, task.deadline
    )
    knots = taylor_knots(
        task.robot,
        line,
        task.q_start,
        q_goal,
        task.position_tolerance,
        task.orientation_tolerance,
        deadline=task.deadline,
        stats=stats,
        reference=reference,
    )
    taylor_count = len(knots)
    knots = check_knot_path(
        task.robot,
        line,
        knots,
        task.position_tolerance,
        task.orientation_tolerance,
        deadline=task.deadline,
        stats=stats,
        reference=reference,
    )
    diagnostics = {
        "midpoint_knot_count": taylor_count,
        "knot_time_ms": 1e3 * (time.perf_counter() - started),
    }
    return finish_knots(
        task,
        line,
        knots,
        stats=stats,
        diagnostics=diagnostics,
        warnings=warnings,
        reference=reference,
    )
