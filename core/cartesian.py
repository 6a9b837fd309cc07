"""The notes' first Cartesian method, ``sampled``: IK at points along the line, every point checked.

``walk_line`` solves IK at equally spaced points of the line (the step derived from the tolerance:
``STEP_PER_TOLERANCE`` times it, between ``MIN_INTERVALS`` and ``MAX_INTERVALS`` intervals), each
seeded where the Jacobian predicts the arm will be, q + dq/ds ds with dq/ds = J^+ V (V: the line's
twist per unit s), so the arm stays on one branch. A step that misbehaves is halved, down to
``MIN_STEP``; what still fails there is the failure, with its cause and s:

- ``unreachable`` (Type I): no IK solution within ``IK_TOLERANCE`` (1e-6 m and rad);
- ``joint_limit``: the solution on the branch being followed leaves the joint limits (IK runs
  without clipping to the limits, so a redundant arm is not slid along a limit off its path);
- ``branch_flip``: a joint step larger than ``BRANCH_RATIO`` times the predicted step plus
  ``BRANCH_ABS`` even for the smallest step (IK on another branch, never accepted silently);
- ``singularity`` (Type II): the smallest singular value of the task Jacobian is below
  ``SINGULAR_VALUE_THRESHOLD``, or joint rates need a slow-down below
  ``core.line_timing.MIN_SPEED_FRACTION`` of the requested speed.

``plan_sampled`` times the walked path with ``core.line_timing.time_path``, places the returned
points (IK at each, seeded from the walk and checked to be on its branch), and returns the planned
prefix with ``fraction`` < 1 when ``allow_partial`` is set.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian_task import CartesianResult, CartesianTask, finish, validated_line
from core.errors import (
    BranchFlip,
    JointLimit,
    PlanningError,
    Singularity,
    Unreachable,
)
from core.geometry import so3
from core.kinematics import Kinematics, jacobians, task_rows
from core.line_timing import (
    MIN_SPEED_FRACTION,
    nominal_path_speed,
    sample_path,
    time_path,
    timed_trajectory,
)
from core.path.line import StraightLine

SINGULAR_VALUE_THRESHOLD = 1e-3
"""Smallest singular value of the task Jacobian [m/rad for the linear rows] below which a point is
singular. At 1e-3 a joint turning at 1 rad/s moves the tool by at most 1 mm/s in the weakest
direction: following the line there needs joint rates ~100 times any arm's limits."""
IK_TOLERANCE = 1e-6
"""Largest IK residual [m] and [rad] of a point accepted as on the line."""
IK_SOLVE_TOLERANCE = 1e-9
"""Residual the IK is asked for (one more Newton step than 1e-6 from a good seed)."""
STEP_PER_TOLERANCE = 10.0
"""Walk step: this many position tolerances [m] of travel, or orientation tolerances [rad]."""
MIN_INTERVALS = 50
MAX_INTERVALS = 2000
MIN_STEP = 1e-5
"""Smallest step in s when a step is halved: where a failure is located."""
MAX_JOINT_STEP = 0.1
"""Largest joint step [rad] the walk predicts in one step; where joints move fast it steps shorter."""
BRANCH_RATIO = 0.5
BRANCH_ABS = 1e-3
"""A step is on the branch when max |q - q_predicted| <= BRANCH_RATIO max |dq_predicted| + BRANCH_ABS [rad]."""
EDGE_PROBE = 1e-3
"""How far past a singular point [in s] IK is tried to tell the workspace's edge (Type I)."""
EDGE_SEED_OFFSET = 0.1
"""[rad] IK seeds on both sides of a singular surface when telling the workspace's edge."""
GOAL_SNAP = 1e-5
"""End configuration within this of ``q_goal`` [rad] is replaced by ``q_goal`` (same solution)."""
GOAL_BRANCH_WARNING = 1e-3
"""End configuration farther than this from ``q_goal`` [rad]: a warning."""
_LIMIT_SLACK = 1e-9
_EXACT = 10.0 * IK_SOLVE_TOLERANCE
"""An IK residual above this (yet within IK_TOLERANCE) means IK could not converge fully."""
_MAX_RETIMES = 4
_TWO_PI = 2.0 * np.pi
RATES_CHUNK = 2048
"""Rows of ``path_rates`` computed between two deadline checks."""
PINV_RCOND = 1e-15
"""Singular values below this share of the largest are dropped from J^+ (np.linalg.pinv's default)."""
BATCH_MIN_POINTS = 8
"""From this many points on, the returned points are first solved together (``_batch_solve``)."""
BATCH_ITERATIONS = 8
"""Newton steps of the batched solve (from the walk's prediction 2-3 reach ``IK_SOLVE_TOLERANCE``)."""
BATCH_DAMPING = 1e-12
"""Damping of the batched Newton steps (regularization only: singular points go the one-point way)."""


class PathRates(NamedTuple):
    """Derivatives of the path q(s) at configurations on the line.

    Attributes:
        dq_ds: ``(N, dof)`` J^+ V [rad per unit s].
        d2q_ds2: ``(N, dof)`` its derivative along the path [rad per unit s^2] (zeros if not asked).
        sigma: ``(N,)`` smallest singular value of the task Jacobian.
    """

    dq_ds: np.ndarray
    d2q_ds2: np.ndarray
    sigma: np.ndarray


def path_rates(
    robot: Kinematics,
    line: StraightLine,
    positions: np.ndarray,
    second_order: bool = True,
    deadline: Deadline = NO_DEADLINE,
) -> PathRates:
    """dq/ds = J^+ V at each row of ``positions`` (N, dof), with V the line's twist per unit s (task
    rows only); d2q/ds2 by a central difference of J^+ V along dq/ds (2 more Jacobians per row).
    ``RATES_CHUNK`` rows at a time, ``deadline`` checked between chunks."""
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    if len(positions) > RATES_CHUNK:
        parts = []
        for i in range(0, len(positions), RATES_CHUNK):
            deadline.check("joint rates along the line")
            parts.append(path_rates(robot, line, positions[i : i + RATES_CHUNK], second_order))
        return PathRates(*(np.concatenate(a) for a in zip(*parts, strict=True)))
    rows = task_rows(robot.task_space)
    V = line.derivative(np.zeros(1))[0][rows]  # per unit s (constant along a line)

    def rates(qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # One SVD gives the smallest singular value and the pseudo-inverse (as np.linalg.pinv
        # builds it, with its default cutoff of 1e-15 times the largest singular value).
        J = jacobians(robot, qs)[:, rows]
        u, sv, vt = np.linalg.svd(J, full_matrices=False)
        smallest = sv[:, -1] if sv.shape[1] == len(rows) else np.zeros(len(qs))
        large = sv > PINV_RCOND * sv.max(axis=-1, keepdims=True)
        inverse = np.divide(1.0, sv, where=large, out=np.zeros_like(sv))
        pinv = np.matmul(np.swapaxes(vt, -1, -2), inverse[..., None] * np.swapaxes(u, -1, -2))
        return np.einsum("nij,j->ni", pinv, V), smallest

    dq, sigma = rates(positions)
    if not second_order:
        return PathRates(dq, np.zeros_like(dq), sigma)
    h = 1e-5 / np.maximum(np.abs(dq).max(axis=1), 1e-3)
    step = h[:, None] * dq
    ahead, _ = rates(positions + step)
    behind, _ = rates(positions - step)
    return PathRates(dq, (ahead - behind) / (2.0 * h[:, None]), sigma)


def check_grid(task: CartesianTask, line: StraightLine) -> np.ndarray:
    """Equally spaced s of the walk: a step of ``STEP_PER_TOLERANCE`` tolerances of travel."""
    n = max(
        line.length / (STEP_PER_TOLERANCE * task.position_tolerance),
        line.angle / (STEP_PER_TOLERANCE * task.orientation_tolerance),
    )
    return np.linspace(0.0, 1.0, int(np.clip(np.ceil(n), MIN_INTERVALS, MAX_INTERVALS)) + 1)


@dataclass(frozen=True)
class LineWalk:
    """IK along the line, up to the first failure.

    Attributes:
        s: Path parameters of the solved points, ``(K,)``, from 0 to the last one reached.
        positions: Their joint positions, ``(K, dof)``, on one branch.
        rates: ``PathRates`` at them (d2q/ds2 included).
        failure: What stopped the walk before s = 1, else None.
        ik_calls: IK solves spent.
    """

    s: np.ndarray
    positions: np.ndarray
    rates: PathRates
    failure: PlanningError | None
    ik_calls: int

    @property
    def end(self) -> float:
        return float(self.s[-1])

    def before(self, s: float) -> LineWalk:
        """The walk cut to the points at least ``MIN_STEP`` before ``s``."""
        keep = self.s <= s - MIN_STEP
        keep[0] = True
        rates = PathRates(*(a[keep] for a in self.rates))
        return replace(self, s=self.s[keep], positions=self.positions[keep], rates=rates)


class _Seed(NamedTuple):
    """A solved point to continue from: joint positions, dq/ds there, and the step in s to take."""

    q: np.ndarray
    dq: np.ndarray
    h: float


class _Walker:
    """One walk's context: the robot, the line, the step checks and the IK call count."""

    def __init__(self, task: CartesianTask, line: StraightLine, nominal_speed: float) -> None:
        self.task, self.robot, self.line = task, task.robot, line
        self.floor = MIN_SPEED_FRACTION * nominal_speed if np.isfinite(nominal_speed) else 0.0
        self.lo, self.hi = self.robot.position_limits[:, 0], self.robot.position_limits[:, 1]
        self.ik_calls = 0
        # IK may not clip its iterates into the joint limits (``robots.Robot.ik`` does by default):
        # clipping would slide a redundant arm along a limit, off the path its rates describe; the
        # limits are checked here instead, on the solution of the branch being followed.
        try:
            roam = "respect_limits" in inspect.signature(self.robot.ik).parameters
        except (TypeError, ValueError):
            roam = False
        self.ik_options = {"respect_limits": False} if roam else {}

    def ik(self, T: np.ndarray, seed: np.ndarray) -> tuple[np.ndarray, bool, float]:
        """(positions, on the line, residual [m or rad])."""
        self.ik_calls += 1
        r = self.robot.ik(
            T,
            seed,
            position_tolerance=IK_SOLVE_TOLERANCE,
            orientation_tolerance=IK_SOLVE_TOLERANCE,
            **self.ik_options,
        )
        residual = max(r.position_error, r.orientation_error)
        return np.asarray(r.positions, dtype=float), bool(residual <= IK_TOLERANCE), residual

    def inside(self, q: np.ndarray) -> bool:
        span = np.maximum(self.hi - self.lo, 1.0)
        return bool(
            np.all(q >= self.lo - _LIMIT_SLACK * span)
            and np.all(q <= self.hi + _LIMIT_SLACK * span)
        )

    def unwrap(self, q: np.ndarray, ref: np.ndarray, T: np.ndarray) -> np.ndarray:
        """``q`` with whole turns removed toward ``ref`` where that keeps the limits and the pose."""
        turns = np.round((q - ref) / _TWO_PI)
        if not turns.any():
            return q
        cand = q - _TWO_PI * turns
        if not self.inside(cand):
            return q
        dp = np.abs(self.robot.fk(cand) - T).max()
        return cand if dp <= IK_TOLERANCE else q

    def reached(self, q: np.ndarray, ok: bool, residual: float) -> bool:
        """IK converged; a loose convergence (residual over ``_EXACT``) at a singular configuration
        does not count: that is the edge of the workspace (a fold), where the line leaves it."""
        if not ok:
            return False
        if residual <= _EXACT:
            return True
        sigma = path_rates(self.robot, self.line, q[None], second_order=False).sigma[0]
        return bool(sigma >= SINGULAR_VALUE_THRESHOLD)

    def on_branch(self, q: np.ndarray, seed: _Seed) -> bool:
        """Whether ``q`` continues the branch from ``seed``: within ``BRANCH_RATIO`` of the
        Jacobian's prediction (plus ``BRANCH_ABS``); or, for a step of at most 2 ``MIN_STEP``,
        within what the larger of the rates at both ends allows (the mean-value bound, which holds
        where the rates grow fast, next to a fold of the workspace or a singularity)."""
        step = seed.dq * seed.h
        if np.abs(q - seed.q - step).max() <= BRANCH_RATIO * np.abs(step).max() + BRANCH_ABS:
            return True
        if abs(seed.h) > 2.0 * MIN_STEP:
            return False
        rates = path_rates(self.robot, self.line, q[None], second_order=False)
        bound = (1.0 + BRANCH_RATIO) * np.maximum(np.abs(step), np.abs(rates.dq_ds[0] * seed.h))
        return bool(np.all(np.abs(q - seed.q) <= bound + BRANCH_ABS))

    def solve(self, s: float, T: np.ndarray, seeds: list[_Seed]) -> np.ndarray | PlanningError:
        """IK at ``T`` (path parameter ``s``) on the branch of the seeds (solved points nearby)."""
        names = self.robot.joint_names
        reached: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        residual = np.inf
        for seed in seeds:
            step = seed.dq * seed.h
            pred = seed.q + step
            for start in (pred, seed.q):
                q, ok, res = self.ik(T, start)
                residual = min(residual, res)
                if not self.reached(q, ok, res):
                    continue
                q = self.unwrap(q, pred, T)
                if self.on_branch(q, seed):
                    if not self.inside(q):
                        j = int(np.argmax(np.maximum(self.lo - q, q - self.hi)))
                        return JointLimit(
                            f"joint {names[j]} leaves its position limits at s={s:.4f}",
                            s=s,
                            joint=j,
                        )
                    return q
                reached = reached or (q, pred, step)
        if reached is not None:
            q, pred, step = reached
            if not self.inside(pred):
                j = int(np.argmax(np.maximum(self.lo - pred, pred - self.hi)))
                return JointLimit(
                    f"joint {names[j]} would leave its position limits at s={s:.4f} on the branch "
                    "the arm is on (IK finds only another branch)",
                    s=s,
                    joint=j,
                )
            j = int(np.argmax(np.abs(q - pred)))
            return BranchFlip(
                f"joint {names[j]} would jump by {abs(q[j] - pred[j] + step[j]):.3g} rad at "
                f"s={s:.4f} where the Jacobian predicts {abs(step[j]):.3g} rad: IK is on another branch",
                s=s,
                joint=j,
            )
        return Unreachable(
            f"no IK solution within {IK_TOLERANCE:g} m at s={s:.4f} (the closest is "
            f"{residual:.3g} off)",
            s=s,
            extra={"residual": residual},
        )

    def advance(
        self, s0: float, q0: np.ndarray, dq0: np.ndarray, s1: float
    ) -> tuple[np.ndarray, PathRates] | PlanningError:
        """One step of the walk from (s0, q0) with rates dq0 to s1: the point and its rates."""
        q = self.solve(s1, self.line.pose(s1), [_Seed(q0, dq0, s1 - s0)])
        if isinstance(q, PlanningError):
            return q
        rates = self.check_point(s1, q)
        return rates if isinstance(rates, PlanningError) else (q, rates)

    def workspace_edge(self, s: float, q: np.ndarray) -> Unreachable | None:
        """A singular point at ``s`` that is the edge of the workspace (a fold: IK fails
        ``EDGE_PROBE`` further on) is a Type I failure: the first unreachable s, by bisection."""
        rows = task_rows(self.robot.task_space)
        J = self.robot.jacobian(q)[rows]
        # Seeds on both sides of the singular surface: along the joint motion the arm loses.
        lost = np.linalg.svd(J)[2][min(len(rows), self.robot.dof) - 1]
        seeds = (q, q + EDGE_SEED_OFFSET * lost, q - EDGE_SEED_OFFSET * lost)

        def reachable(at: float, starts: tuple[np.ndarray, ...] = seeds) -> tuple[bool, float]:
            best = np.inf
            for seed in starts:
                found, ok, res = self.ik(self.line.pose(at), seed)
                if self.reached(found, ok, res):
                    return True, res
                best = min(best, res)
            return False, best

        lo, hi = s, min(1.0, s + EDGE_PROBE)
        if hi <= lo:
            return None
        # Reachable on another branch (seeds spread over the joint space) is not an edge.
        rng = np.random.default_rng(0)
        spread = rng.uniform(np.maximum(self.lo, -np.pi), np.minimum(self.hi, np.pi), (8, len(q)))
        found, residual = reachable(hi, seeds + tuple(spread))
        if found:
            return None
        while hi - lo > MIN_STEP:
            mid = 0.5 * (lo + hi)
            found, res = reachable(mid)
            if found:
                lo = mid
            else:
                hi, residual = mid, res
        return Unreachable(
            f"no IK solution within {IK_TOLERANCE:g} m at s={hi:.4f}: the line leaves the "
            f"workspace there (the closest is {residual:.3g} off; the arm is singular at the edge)",
            s=hi,
            extra={"residual": residual},
        )

    def check_point(self, s: float, q: np.ndarray) -> PathRates | PlanningError:
        """Rates at ``q`` and the Type II checks."""
        rates = path_rates(self.robot, self.line, q[None], second_order=False)
        sigma = float(rates.sigma[0])
        if sigma < SINGULAR_VALUE_THRESHOLD:
            return Singularity(
                f"the Jacobian is singular at s={s:.4f} (smallest singular value {sigma:.3g} < "
                f"{SINGULAR_VALUE_THRESHOLD:g}): the line needs motion the arm cannot give",
                s=s,
                extra={"min_singular_value": sigma},
            )
        with np.errstate(divide="ignore"):
            cap = float(np.min(self.robot.velocity_limits / np.abs(rates.dq_ds[0])))
        if cap < self.floor:
            return Singularity(
                f"joint rates at s={s:.4f} would need the tool slowed below "
                f"{MIN_SPEED_FRACTION:.1%} of its speed: no finite slow-down keeps them within limits",
                s=s,
                extra={"min_singular_value": sigma},
            )
        return rates


def walk_line(task: CartesianTask, line: StraightLine, grid: np.ndarray | None = None) -> LineWalk:
    """IK along ``line`` from ``task.q_start`` (see the module docstring); stops at the first failure.

    Args:
        grid: Path parameters to solve at, increasing from 0 to 1 (default ``check_grid``).
    """
    w = _Walker(task, line, nominal_path_speed(task, line))
    grid = check_grid(task, line) if grid is None else np.asarray(grid, dtype=float)
    q = np.asarray(task.q_start, dtype=float)
    needed = len(task_rows(task.robot.task_space))
    if task.robot.dof < needed:
        raise Singularity(
            f"the arm has {task.robot.dof} joints, fewer than the {needed} a line in its task space "
            "needs: its Jacobian is singular everywhere",
            s=0.0,
            extra={"min_singular_value": 0.0},
        )
    first = w.check_point(0.0, q)
    if isinstance(first, PlanningError):
        raise first
    s_list, q_list, dq_list = [0.0], [q], [first.dq_ds[0]]
    failure: PlanningError | None = None
    s_cur, h_max = 0.0, float(np.max(np.diff(grid)))
    h = h_max
    for target in grid[1:]:
        while failure is None and s_cur < target:
            task.deadline.check("sampled IK along the line")
            fastest = float(np.abs(dq_list[-1]).max())
            if fastest * h > MAX_JOINT_STEP:  # the prediction is only good for small joint steps
                h = max(MAX_JOINT_STEP / fastest, MIN_STEP)
            s_try = target if target - (s_cur + h) < 0.5 * MIN_STEP else s_cur + h
            out = w.advance(s_cur, q_list[-1], dq_list[-1], s_try)
            if isinstance(out, PlanningError):
                if s_try - s_cur <= MIN_STEP:
                    failure = out
                    if isinstance(out, Singularity):
                        failure = w.workspace_edge(s_try, q_list[-1]) or out
                h = 0.5 * (s_try - s_cur)
                continue
            s_list.append(s_try)
            q_list.append(out[0])
            dq_list.append(out[1].dq_ds[0])
            s_cur, h = s_try, min(2.0 * h, h_max)
        if failure is not None:
            break
    positions = np.array(q_list)
    rates = path_rates(task.robot, line, positions, deadline=task.deadline)
    return LineWalk(np.array(s_list), positions, rates, failure, w.ik_calls)


def solve_on_line(
    task: CartesianTask, line: StraightLine, walk: LineWalk, s: np.ndarray
) -> np.ndarray:
    """Joint positions ``(N, dof)`` on the line at ``s`` (N,), on the walk's branch: a point of the
    walk is reused; any other is solved by IK seeded from the walk point before it (then after it).
    Raises the failure (with its s) of a point that cannot be solved on the branch."""
    return _solve_points(_Walker(task, line, 0.0), walk, s)


def _solve_points(w: _Walker, walk: LineWalk, s: np.ndarray) -> np.ndarray:
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
            _Seed(walk.positions[kk], dq[kk], si - walk.s[kk])
            for kk in (ki, ki + 1)[: 1 + (ki + 1 < len(walk.s))]
        ]
        q = w.solve(float(si), poses[i], seeds)
        if isinstance(q, PlanningError):
            raise q
        out[i] = q
    return out


def _batch_solve(
    w: _Walker, walk: LineWalk, s: np.ndarray, k: np.ndarray, poses: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """The fast path of ``_solve_points``: every point at once, by damped Newton steps vectorized
    over the points (``fk_jacobian_many``), each from the start the one-point path tries first
    (its walk point before it, stepped by the rates there). A point is taken, into ``out``, only
    when it passes that path's tests of its first attempt: residual within ``IK_SOLVE_TOLERANCE``,
    no whole turns to remove, on the branch (``BRANCH_RATIO``), inside the limits. Returns which
    points were taken; the others (and robots without ``fk_jacobian_many``, or a task space other
    than ``pose``) go through the one-point path, with its fallbacks and its errors."""
    robot = w.robot
    taken = np.zeros(len(s), dtype=bool)
    many = getattr(robot, "fk_jacobian_many", None)
    todo = np.flatnonzero(s != walk.s[k])
    if many is None or robot.task_space != "pose" or len(todo) < BATCH_MIN_POINTS:
        return taken
    for i in range(0, len(todo), RATES_CHUNK):  # a chunk per deadline check
        _batch_chunk(w, walk, s, k, poses, out, taken, todo[i : i + RATES_CHUNK], many)
    w.ik_calls += len(todo)
    return taken


def _batch_chunk(
    w: _Walker,
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
    q0, h = walk.positions[k[todo]], (s - walk.s[k])[todo]
    step = walk.rates.dq_ds[k[todo]] * h[:, None]
    q = q0 + step
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
    turns = np.round((q - q0 - step) / _TWO_PI).any(axis=1)
    off = np.abs(q - q0 - step).max(axis=1) > BRANCH_RATIO * np.abs(step).max(axis=1) + BRANCH_ABS
    span = np.maximum(w.hi - w.lo, 1.0)
    inside = np.all((q >= w.lo - _LIMIT_SLACK * span) & (q <= w.hi + _LIMIT_SLACK * span), axis=1)
    ok = converged & ~turns & ~off & inside
    out[todo[ok]] = q[ok]
    taken[todo[ok]] = True


def plan_sampled(task: CartesianTask) -> CartesianResult:
    """Plan ``task`` by sampled IK along the line (see the module docstring)."""
    line = validated_line(task)
    walk = walk_line(task, line)
    failure, attempts = walk.failure, 0
    while True:
        if failure is not None and (not task.allow_partial or walk.end <= MIN_STEP):
            raise failure
        try:
            return _timed_result(task, line, walk, failure)
        except (Unreachable, JointLimit, BranchFlip, Singularity) as err:
            # A returned point between walked points failed: with allow_partial, stop before it.
            attempts += 1
            if not task.allow_partial or err.s is None or attempts >= 3:
                raise
            walk, failure = walk.before(err.s), err


def _timed_result(
    task: CartesianTask, line: StraightLine, walk: LineWalk, failure: PlanningError | None
) -> CartesianResult:
    robot = task.robot
    grid_s, grid_rates = walk.s, walk.rates
    solver = _Walker(task, line, 0.0)
    cache: dict[float, np.ndarray] = {}
    for retimes in range(_MAX_RETIMES):  # noqa: B007
        timing = time_path(task, line, grid_s, grid_rates.dq_ds, grid_rates.d2q_ds2)
        times, s = sample_path(task, timing)
        todo = np.array([x for x in s if x not in cache])
        if len(todo):
            cache.update(zip(todo.tolist(), _solve_points(solver, walk, todo), strict=True))
        q = np.array([cache[x] for x in s.tolist()])
        rates = path_rates(robot, line, q, deadline=task.deadline)
        singular = rates.sigma < SINGULAR_VALUE_THRESHOLD
        if singular.any():
            i = int(np.argmax(singular))
            raise Singularity(
                f"the Jacobian is singular at s={s[i]:.4f} between walked points (smallest singular "
                f"value {rates.sigma[i]:.3g})",
                s=float(s[i]),
            )
        traj = timed_trajectory(times, timing, q, rates.dq_ds, rates.d2q_ds2, robot.joint_names)
        over = (np.abs(traj.velocities) > robot.velocity_limits * (1.0 + 1e-9)).any(axis=1)
        if not over.any():
            break
        # A returned point between grid points needs a lower cap: add it to the grid and re-time.
        grid_s, order = np.unique(np.concatenate([grid_s, s[over]]), return_index=True)
        grid_rates = PathRates(
            *(np.concatenate([a, b[over]])[order] for a, b in zip(grid_rates, rates, strict=True))
        )
    warnings = list(timing.warnings)
    acc_ratio = traj.peak_acceleration / robot.acceleration_limits
    if task.duration is None and acc_ratio.max() > 1.0 + 1e-6:
        j = int(np.argmax(acc_ratio))
        warnings.append(
            f"joint {robot.joint_names[j]} accelerates at {acc_ratio[j]:.3g} times its limit "
            "between the points the timing was computed at"
        )
    if failure is not None:
        warnings.insert(0, f"planned {walk.end:.1%} of the line: {failure.detail}")
    elif task.q_goal is not None:
        gap = float(np.abs(traj.positions[-1] - task.q_goal).max())
        if gap <= GOAL_SNAP:
            traj.positions[-1] = task.q_goal
        elif gap > GOAL_BRANCH_WARNING:
            warnings.append(
                f"the line ends at the goal pose in another joint configuration than "
                f"goal.positions (up to {gap:.3g} rad apart); the trajectory ends where the line "
                "leads, without a branch flip"
            )
    result = CartesianResult(
        trajectory=traj,
        fraction=walk.end,
        warnings=warnings,
        diagnostics={
            "ik_points": len(walk.s),
            "ik_calls": walk.ik_calls + solver.ik_calls,
            "slowdown": timing.slowdown,
            "retimes": retimes,
        },
        failure=failure,
    )
    finish(task, result, s)
    dev = result.deviation
    if dev is not None and (
        dev.max_position > task.position_tolerance
        or dev.max_orientation > task.orientation_tolerance
    ):
        result.warnings.append(
            f"between returned points the arm strays up to {dev.max_position:.3g} m / "
            f"{dev.max_orientation:.3g} rad from the line, over the tolerance: "
            "return more points (samples or a smaller sample_period)"
        )
    return result
