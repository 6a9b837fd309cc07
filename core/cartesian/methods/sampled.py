"""The notes' first Cartesian method, ``sampled``: IK at points along the line, every point checked.

``core.cartesian.walk`` walks the line (``core.cartesian.walk_batch`` first tries it in one batch,
for arms with configuration labels); ``plan_sampled`` times the walked path with
``core.cartesian.timing.time_path``, places the returned points (IK at each, seeded from the walk and
checked to be on its branch; many points at once by batched Newton steps, ``_batch_solve``), and
returns the planned prefix with ``fraction`` < 1 when ``allow_partial`` is set.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from core.cartesian.check import finish
from core.cartesian.ik_on_path import IK_SOLVE_TOLERANCE, follows, label_note
from core.cartesian.measure import min_singular_values
from core.cartesian.partial import PARTIAL_ERRORS, PARTIAL_TRIES, partial_warning
from core.cartesian.path_rates import RATES_CHUNK, PathRates, path_rates, predict
from core.cartesian.task import CartesianResult, CartesianTask
from core.cartesian.timing import sample_path, time_path, timed_trajectory
from core.cartesian.validate import validated_line
from core.cartesian.walk import (
    GOAL_BRANCH_WARNING,
    GOAL_SNAP,
    MAX_INTERVALS,
    MIN_STEP,
    TWO_PI,
    LineWalk,
    Seed,
    Walker,
    check_grid,
    walk_line,
)
from core.cartesian.walk_batch import batch_walk
from core.errors import (
    PlanningError,
    Singularity,
)
from core.geometry import so3
from core.kinematics import SINGULAR_VALUE_THRESHOLD
from core.limits import inside, over_speed
from core.path.base import Path
from core.trajectory import DEFAULT_SAMPLE_PERIOD, MAX_POINTS

_MAX_RETIMES = 4
DENSIFY_FACTOR = 4.0
"""Returned points this many times closer per densifying round."""
DENSIFY_ROUNDS = 3
"""Most densifying rounds (0.01 s down to 0.16 ms)."""
BATCH_MIN_POINTS = 8
"""From this many points on, the returned points are first solved together (``_batch_solve``)."""
BATCH_ITERATIONS = 8
"""Newton steps of the batched solve (from the walk's prediction 2-3 reach ``IK_SOLVE_TOLERANCE``)."""
BATCH_DAMPING = 1e-12
"""Damping of the batched Newton steps (regularization only: singular points go the one-point way)."""


def solve_on_line(task: CartesianTask, line: Path, walk: LineWalk, s: np.ndarray) -> np.ndarray:
    """Joint positions ``(N, dof)`` on the line at ``s`` (N,), on the walk's branch: a point of the
    walk is reused; any other is solved by IK seeded from the walk point before it (then after it).
    Raises the failure (with its s) of a point that cannot be solved on the branch."""
    return _solve_points(Walker(task, line, 0.0), walk, s)


def _solve_points(w: Walker, walk: LineWalk, s: np.ndarray) -> np.ndarray:
    task, line = w.task, w.line
    k = np.clip(np.searchsorted(walk.s, s, side="right") - 1, 0, len(walk.s) - 1)
    poses = line.poses(s)
    out = np.empty((len(s), task.robot.dof))
    dq = walk.rates.dq_ds
    solved = _batch_solve(w, walk, s, k, poses, out)
    for i, (si, ki) in enumerate(zip(s, k, strict=True)):
        if i % 64 == 0:
            task.deadline.check("sampled IK at the returned points")
        if solved[i]:
            continue
        if si == walk.s[ki]:
            out[i] = walk.positions[ki]
            continue
        # Seeded like the walk's own steps (first order), so that for a redundant arm the
        # points between two walk points continue those points' null-space choice.
        seeds = [
            Seed(walk.positions[kk], dq[kk], si - walk.s[kk])
            for kk in (ki, ki + 1)[: 1 + (ki + 1 < len(walk.s))]
        ]
        q = w.solve(float(si), poses[i], seeds)
        if isinstance(q, PlanningError):
            raise q
        out[i] = q
    return out


def _batch_solve(
    w: Walker, walk: LineWalk, s: np.ndarray, k: np.ndarray, poses: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """The fast path of ``_solve_points``: every point at once, by damped Newton steps vectorized
    over the points (``fk_jacobian_many``), each from the start the one-point path tries first
    (its walk point before it, stepped by the rates there). A point is taken, into ``out``, only
    when it passes that path's tests of its first attempt: residual within ``IK_SOLVE_TOLERANCE``,
    no whole turns to remove, on the branch (``follows``), inside the limits. Returns which
    points were taken; the others (and every point when the task space is not
    ``pose``) go through the one-point path, with its fallbacks and its errors."""
    robot = w.robot
    taken = np.zeros(len(s), dtype=bool)
    many = robot.fk_jacobian_many
    todo = np.flatnonzero(s != walk.s[k])
    if robot.task_space != "pose" or len(todo) < BATCH_MIN_POINTS:
        return taken
    for i in range(0, len(todo), RATES_CHUNK):  # a chunk per deadline check
        _batch_chunk(w, walk, s, k, poses, out, taken, todo[i : i + RATES_CHUNK], many)
    w.ik_calls += len(todo)
    return taken


def _batch_chunk(
    w: Walker,
    walk: LineWalk,
    s: np.ndarray,
    k: np.ndarray,
    poses: np.ndarray,
    out: np.ndarray,
    taken: np.ndarray,
    todo: np.ndarray,
    many: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
) -> None:
    """``_batch_solve`` on the points ``todo`` (indices into ``s``), in place."""
    q0, h, dq = walk.positions[k[todo]], (s - walk.s[k])[todo], walk.rates.dq_ds[k[todo]]
    step = dq * h[:, None]
    q = predict(w.robot, w.line, q0, dq, walk.s[k[todo]], h)
    p_goal, R_goal = poses[todo, :3, 3], poses[todo, :3, :3]
    active = np.ones(len(todo), dtype=bool)
    converged = np.zeros(len(todo), dtype=bool)
    eye = BATCH_DAMPING * np.eye(6)
    for _ in range(BATCH_ITERATIONS):
        w.task.deadline.check("sampled IK at the returned points")
        T, J = many(q[active])
        e_p = p_goal[active] - T[:, :3, 3]
        R_err = R_goal[active] @ np.swapaxes(T[:, :3, :3], 1, 2)
        # Beyond a quarter turn from the goal Newton is no help: NaN fails the tolerance test.
        within = np.trace(R_err, axis1=1, axis2=2) > 1.0
        e_o = np.where(within[:, None], so3.log(R_err), np.nan)
        done = (np.einsum("ij,ij->i", e_p, e_p) <= IK_SOLVE_TOLERANCE**2) & (
            np.einsum("ij,ij->i", e_o, e_o) <= IK_SOLVE_TOLERANCE**2
        )
        idx = np.flatnonzero(active)
        converged[idx[done]] = True
        active[idx[done]] = False
        if not active.any():
            break
        e = np.concatenate([e_p, e_o], axis=1)[~done]
        Jn = J[~done]
        JT = np.swapaxes(Jn, 1, 2)
        try:
            q[active] += (JT @ np.linalg.solve(Jn @ JT + eye, e[:, :, None]))[:, :, 0]
        except np.linalg.LinAlgError:  # a numerically singular point: all go the one-point way
            break
    turns = np.round((q - q0 - step) / TWO_PI).any(axis=1)
    off = ~follows(q, q0, step)
    ok = converged & ~turns & ~off & inside(q, w.robot.position_limits)
    out[todo[ok]] = q[ok]
    taken[todo[ok]] = True


def plan_sampled(task: CartesianTask) -> CartesianResult:
    """Plan ``task`` by sampled IK along the line (see the module docstring)."""
    line = validated_line(task)
    walk = batch_walk(task, line, _returned_grid(task, line)) or walk_line(task, line)
    failure, attempts = walk.failure, 0
    while True:
        if failure is not None and (not task.allow_partial or walk.end <= MIN_STEP):
            raise failure
        try:
            return _densified(task, line, walk, failure)
        except PARTIAL_ERRORS as err:
            # A returned point between walked points failed: with allow_partial, stop before it.
            attempts += 1
            if not task.allow_partial or err.s is None or attempts >= PARTIAL_TRIES:
                raise
            walk, failure = walk.before(err.s), err


def _returned_grid(task: CartesianTask, line: Path) -> np.ndarray | None:
    """With ``samples`` the returned points' s are known before the timing (equally spaced):
    the batched walk solves them directly (and the timing reads its caps there) when they are at
    least as dense as its own grid and no more than its largest (``MAX_INTERVALS``); else None
    (the walk's grid, then IK at the returned points, under the deadline)."""
    if task.samples is None or task.samples > MAX_INTERVALS + 1:
        return None  # (the walk's own grid is bounded: IK of one batch, deadline checks between)
    grid = np.linspace(0.0, 1.0, int(task.samples))
    return grid if len(grid) >= len(check_grid(task, line)) else None


def _densified(
    task: CartesianTask, line: Path, walk: LineWalk, failure: PlanningError | None
) -> CartesianResult:
    """``_timed_result``; when the request left the sampling to the service (neither ``samples``
    nor ``sample_period``) and interpolation between the points strays over the tolerance, the
    points are placed ``DENSIFY_FACTOR`` times closer, up to ``DENSIFY_ROUNDS`` times and
    ``MAX_POINTS`` points (issue 19: densify where the request leaves room)."""
    result = _timed_result(task, line, walk, failure)
    if task.samples is not None or task.sample_period is not None:
        return result
    period = DEFAULT_SAMPLE_PERIOD
    for _ in range(DENSIFY_ROUNDS):
        dev = result.deviation
        within = dev is None or (
            dev.max_position <= task.position_tolerance
            and dev.max_orientation <= task.orientation_tolerance
        )
        period /= DENSIFY_FACTOR
        if within or result.trajectory.duration / period > MAX_POINTS:
            break
        result = _timed_result(replace(task, sample_period=period), line, walk, failure)
    return result


def _point_rates(
    task: CartesianTask, line: Path, walk: LineWalk, s: np.ndarray, q: np.ndarray
) -> PathRates:
    """The path rates at the returned points ``q`` (at ``s``): the walk's own when it solved
    exactly those points; ``Singularity`` where one is singular."""
    if np.array_equal(s, walk.s):
        rates = walk.rates
    else:
        rates = path_rates(task.robot, line, q, deadline=task.deadline)
    singular = rates.sigma < SINGULAR_VALUE_THRESHOLD
    if singular.any():
        i = int(np.argmax(singular))
        raise Singularity(
            f"the Jacobian is singular at s={s[i]:.4f} between walked points (smallest singular "
            f"value {rates.sigma[i]:.3g})",
            s=float(s[i]),
        )
    return rates


def _timed_result(
    task: CartesianTask, line: Path, walk: LineWalk, failure: PlanningError | None
) -> CartesianResult:
    robot = task.robot
    grid_s, grid_rates = walk.s, walk.rates
    solver = Walker(task, line, 0.0)
    cache: dict[float, np.ndarray] = {}
    for retimes in range(_MAX_RETIMES):  # noqa: B007
        timing = time_path(task, line, grid_s, grid_rates.dq_ds, grid_rates.d2q_ds2)
        times, s = sample_path(task, timing)
        todo = np.array([x for x in s if x not in cache])
        if len(todo):
            cache.update(zip(todo.tolist(), _solve_points(solver, walk, todo), strict=True))
        q = np.array([cache[x] for x in s.tolist()])
        rates = _point_rates(task, line, walk, s, q)
        traj = timed_trajectory(times, timing, q, rates.dq_ds, rates.d2q_ds2, robot.joint_names)
        over = over_speed(traj.velocities, robot.velocity_limits).any(axis=1)
        if not over.any():
            break
        # A returned point between grid points needs a lower cap: add it to the grid and re-time.
        grid_s, order = np.unique(np.concatenate([grid_s, s[over]]), return_index=True)
        grid_rates = PathRates(
            *(np.concatenate([a, b[over]])[order] for a, b in zip(grid_rates, rates, strict=True))
        )
    warnings = list(timing.warnings)
    sigma: np.ndarray | None = rates.sigma  # (at the returned points)
    acc_ratio = traj.peak_acceleration / robot.acceleration_limits
    if task.duration is None and acc_ratio.max() > 1.0 + 1e-6:
        j = int(np.argmax(acc_ratio))
        warnings.append(
            f"joint {robot.joint_names[j]} accelerates at {acc_ratio[j]:.3g} times its limit "
            "between the points the timing was computed at"
        )
    if failure is not None:
        warnings.insert(0, partial_warning(walk.end, failure))
    elif task.q_goal is not None:
        gap = float(np.abs(traj.positions[-1] - task.q_goal).max())
        if gap <= GOAL_SNAP:
            traj.positions[-1] = task.q_goal
            sigma = np.append(rates.sigma[:-1], min_singular_values(robot, task.q_goal[None]))
        elif gap > GOAL_BRANCH_WARNING:
            warnings.append(
                f"the line ends at the goal pose in another joint configuration than "
                f"goal.positions (up to {gap:.3g} rad apart"
                f"{label_note(robot, task.q_start, task.q_goal)}); the trajectory ends where the "
                "line leads, without a branch flip"
            )
    result = CartesianResult(
        trajectory=traj,
        singular_values=sigma,
        fraction=walk.end,
        warnings=tuple(warnings),
        diagnostics={
            "ik_points": len(walk.s),
            "ik_calls": walk.ik_calls + solver.ik_calls,
            "slowdown": timing.slowdown,
            "retimes": retimes,
        },
        failure=failure,
    )
    result = finish(task, result, s)
    dev = result.deviation
    if dev is not None and (
        dev.max_position > task.position_tolerance
        or dev.max_orientation > task.orientation_tolerance
    ):
        strays = (
            f"between returned points the arm strays up to {dev.max_position:.3g} m / "
            f"{dev.max_orientation:.3g} rad from the line, over the tolerance: "
            "return more points (samples or a smaller sample_period)"
        )
        result = replace(result, warnings=(*result.warnings, strays))
    return result
