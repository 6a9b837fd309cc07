"""The walk of the ``sampled`` method: IK at points along the line, every point checked.

``walk_line`` solves IK at equally spaced points of the line (the step derived from the tolerance:
``STEP_PER_TOLERANCE`` times it, between ``MIN_INTERVALS`` and ``MAX_INTERVALS`` intervals), each
seeded where the Jacobian predicts the arm will be, q + dq/ds ds with dq/ds = J^+ V (V: the line's
twist per unit s), so the arm stays on one branch. A step that misbehaves is halved, down to
``MIN_STEP``; what still fails there is the failure, with its cause and s:

- ``unreachable`` (Type I): no IK solution within ``IK_TOLERANCE`` (1e-6 m and rad); with labels
  (``robot.configuration``) exactly: ``ik_all`` has none (``ik_on_path.on_label``);
- ``joint_limit``: the solution on the branch being followed leaves the joint limits (IK runs
  without clipping to the limits, so a redundant arm is not slid along a limit off its path);
- ``branch_flip``: with labels, the pose has solutions only with other labels than the start's, or
  a walked point carries another label; without, a joint step off the Jacobian's prediction by
  more than ``STRICT_BRANCH`` (``ik_on_path.follows``) even for the smallest step;
- ``singularity`` (Type II): the smallest singular value of the task Jacobian is below
  ``SINGULAR_VALUE_THRESHOLD``, or joint rates need a slow-down below
  ``core.cartesian.timing.MIN_SPEED_FRACTION`` of the requested speed.
``plan_sampled`` times the walked path, places the returned points and returns the planned prefix
with ``fraction`` < 1 when ``allow_partial`` is set (``core.cartesian.methods.sampled``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from core.cartesian.ik_on_path import (
    IK_SOLVE_TOLERANCE,
    IK_TOLERANCE,
    STRICT_BRANCH,
    follows,
    label_change,
    on_label,
    residual,
    solve_ik,
)
from core.cartesian.path_rates import PathRates, path_rates, predict
from core.cartesian.task import CartesianTask
from core.cartesian.timing import MIN_SPEED_FRACTION, nominal_path_speed
from core.errors import (
    BranchFlip,
    JointLimit,
    PlanningError,
    Singularity,
    Unreachable,
)
from core.kinematics import SINGULAR_VALUE_THRESHOLD, task_rows
from core.limits import inside, worst_joint
from core.path.base import Path

STEP_PER_TOLERANCE = 10.0
"""Walk step: this many position tolerances [m] of travel, or orientation tolerances [rad]."""
MIN_INTERVALS = 50
MAX_INTERVALS = 2000
MIN_STEP = 1e-5
"""Smallest step in s when a step is halved: where a failure is located."""
MAX_JOINT_STEP = 0.1
"""Largest joint step [rad] the walk predicts in one step; where joints move fast it steps shorter."""
EDGE_PROBE = 1e-3
"""How far past a singular point [in s] IK is tried to tell the workspace's edge (Type I)."""
EDGE_SEED_OFFSET = 0.1
"""[rad] IK seeds on both sides of a singular surface when telling the workspace's edge."""
GOAL_SNAP = 1e-5
"""End configuration within this of ``q_goal`` [rad] is replaced by ``q_goal`` (same solution)."""
GOAL_BRANCH_WARNING = 1e-3
"""End configuration farther than this from ``q_goal`` [rad]: a warning."""
_EXACT = 10.0 * IK_SOLVE_TOLERANCE
"""An IK residual above this (yet within IK_TOLERANCE) means IK could not converge fully."""

TWO_PI = 2.0 * np.pi


def check_grid(task: CartesianTask, line: Path) -> np.ndarray:
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


class Seed(NamedTuple):
    """A solved point to continue from: joint positions, dq/ds there, and the step in s to take."""

    q: np.ndarray
    dq: np.ndarray
    h: float


class Walker:
    """One walk's context: the robot, the line, the step checks and the IK call count."""

    def __init__(self, task: CartesianTask, line: Path, nominal_speed: float) -> None:
        self.task, self.robot, self.line = task, task.robot, line
        self.floor = MIN_SPEED_FRACTION * nominal_speed if np.isfinite(nominal_speed) else 0.0
        self.lo, self.hi = self.robot.position_limits[:, 0], self.robot.position_limits[:, 1]
        self.ik_calls = 0
        self.label = self.robot.configuration(np.asarray(task.q_start, dtype=float))
        # IK must not clip its iterates into the joint limits (``robots.Robot.ik`` does by default):
        # clipping would slide a redundant arm along a limit, off the path its rates describe; the
        # limits are checked here instead, on the solution of the branch being followed.

    def ik(self, T: np.ndarray, seed: np.ndarray) -> tuple[np.ndarray, bool, float]:
        """(positions, on the line, residual [m or rad])."""
        self.ik_calls += 1
        r = solve_ik(self.robot, T, seed)
        res = residual(r)
        return np.asarray(r.positions, dtype=float), bool(res <= IK_TOLERANCE), res

    def inside(self, q: np.ndarray) -> bool:
        return bool(inside(q, self.robot.position_limits))

    def unwrap(self, q: np.ndarray, ref: np.ndarray, T: np.ndarray) -> np.ndarray:
        """``q`` with whole turns removed toward ``ref`` where that keeps the limits and the pose."""
        turns = np.round((q - ref) / TWO_PI)
        if not turns.any():
            return q
        cand = q - TWO_PI * turns
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
        # sigma does not depend on s: skip the closest-point search
        sigma = path_rates(self.robot, self.line, q[None], False, s=np.zeros(1)).sigma[0]
        return bool(sigma >= SINGULAR_VALUE_THRESHOLD)

    def on_branch(self, q: np.ndarray, seed: Seed, s: float | None = None) -> bool:
        """Whether ``q`` continues the branch from ``seed``: within ``STRICT_BRANCH`` of the
        Jacobian's prediction (plus its slack); or, for a step of at most 2 ``MIN_STEP``,
        within what the larger of the rates at both ends allows (the mean-value bound, which holds
        where the rates grow fast, next to a fold of the workspace or a singularity)."""
        step = seed.dq * seed.h
        if follows(q, seed.q, step):
            return True
        if abs(seed.h) > 2.0 * MIN_STEP:
            return False
        at = None if s is None else np.array([s])
        rates = path_rates(self.robot, self.line, q[None], second_order=False, s=at)
        ratio, slack = STRICT_BRANCH
        bound = (1.0 + ratio) * np.maximum(np.abs(step), np.abs(rates.dq_ds[0] * seed.h))
        return bool(np.all(np.abs(q - seed.q) <= bound + slack))

    def solve(self, s: float, T: np.ndarray, seeds: list[Seed]) -> np.ndarray | PlanningError:
        """IK at ``T`` (path parameter ``s``) on the branch of the seeds (solved points nearby)."""
        names = self.robot.joint_names
        reached: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        residual = np.inf
        for seed in seeds:
            step = seed.dq * seed.h
            h = np.array([seed.h])  # IK starts where the rates lead (path_rates.predict)
            pred = predict(self.robot, self.line, seed.q, seed.dq, s - h, h)[0]
            for start in (pred, seed.q):
                q, ok, res = self.ik(T, start)
                residual = min(residual, res)
                if not self.reached(q, ok, res):
                    continue
                q = self.unwrap(q, pred, T)
                if self.on_branch(q, seed, s):
                    if not self.inside(q):
                        j = worst_joint(q, self.robot.position_limits)
                        return JointLimit(
                            f"joint {names[j]} leaves its position limits at s={s:.4f}",
                            s=s,
                            joint=j,
                        )
                    return q
                reached = reached or (q, pred, step)
        if self.label is not None:
            exact = self.exact(s, T, seeds[0])
            if not isinstance(exact, BranchFlip) or reached is None or self.inside(reached[1]):
                return exact
        if reached is not None:
            q, pred, step = reached
            if not self.inside(pred):
                j = worst_joint(pred, self.robot.position_limits)
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

    def exact(self, s: float, T: np.ndarray, seed: Seed) -> np.ndarray | PlanningError:
        """Robots with labels, where IK from the seeds failed: the solution with the start's
        label (``on_label``, every solution of the pose) when it continues the branch, else why
        not (``Unreachable``, ``JointLimit``, ``BranchFlip`` also when it would jump)."""
        pred = seed.q + seed.dq * seed.h
        self.ik_calls += 1
        try:
            found = on_label(self.robot, T, s, str(self.label), pred)
        except PlanningError as err:
            return err
        q = self.unwrap(found, pred, T)
        if not self.on_branch(q, seed, s):
            # at a singular point (the workspace's edge) the rates cannot predict the step: the
            # point is taken, and its check reports the singularity (then the edge, exactly)
            sigma = path_rates(self.robot, self.line, q[None], False, s=np.zeros(1)).sigma[0]
            if sigma >= SINGULAR_VALUE_THRESHOLD:
                return BranchFlip(
                    f"the solution in the start's configuration ({self.label}) at s={s:.4f} is "
                    "not where the Jacobian predicts the arm: it would jump there",
                    s=s,
                )
        if not self.inside(q):
            j = worst_joint(q, self.robot.position_limits)
            return JointLimit(
                f"joint {self.robot.joint_names[j]} leaves its position limits at s={s:.4f}",
                s=s,
                joint=j,
            )
        return q

    def advance(
        self, s0: float, q0: np.ndarray, dq0: np.ndarray, s1: float
    ) -> tuple[np.ndarray, PathRates] | PlanningError:
        """One step of the walk from (s0, q0) with rates dq0 to s1: the point and its rates."""
        q = self.solve(s1, self.line.pose(s1), [Seed(q0, dq0, s1 - s0)])
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
            if self.label is not None:  # every solution is known: reachable exactly
                self.ik_calls += 1
                sols = self.robot.ik_all(self.line.pose(at), q)
                return bool(len(sols.positions) or sols.outside_limits), np.nan
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
        closest = "" if np.isnan(residual) else f"the closest is {residual:.3g} off; "
        return Unreachable(
            f"no IK solution within {IK_TOLERANCE:g} m at s={hi:.4f}: the line leaves the "
            f"workspace there ({closest}the arm is singular at the edge)",
            s=hi,
            extra={} if np.isnan(residual) else {"residual": residual},
        )

    def check_point(self, s: float, q: np.ndarray) -> PathRates | PlanningError:
        """Rates at ``q`` (the path's point ``s``) and the Type II checks."""
        rates = path_rates(self.robot, self.line, q[None], second_order=False, s=np.array([s]))
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


def walk_line(task: CartesianTask, line: Path, grid: np.ndarray | None = None) -> LineWalk:
    """IK along ``line`` from ``task.q_start`` (see the module docstring); stops at the first failure.

    Args:
        grid: Path parameters to solve at, increasing from 0 to 1 (default ``check_grid``).
    """
    w = Walker(task, line, nominal_path_speed(task, line))
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
    positions, s_arr = np.array(q_list), np.array(s_list)
    if w.label is not None:  # the start's configuration at every walked point (exact)
        off = np.flatnonzero(np.array(task.robot.configurations(positions)) != w.label)
        if len(off):
            failure = label_change(float(s_arr[off[0]]), w.label)
            positions, s_arr = positions[: off[0]], s_arr[: off[0]]
    rates = path_rates(task.robot, line, positions, deadline=task.deadline, s=s_arr)
    return LineWalk(s_arr, positions, rates, failure, w.ik_calls)
