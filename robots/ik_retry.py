"""One IK solution that does not give up early: ``ik_all``, then a second effort when it finds none.

``ik_all`` holds a redundant arm's extra joints at the seed's values (or ``fixed_joints``) and starts
its numeric search from 26 points, so a pose reachable only with those joints elsewhere, or whose
solutions those starts miss, comes back empty (Kinova Gen3, Sawyer, Baxter, YuMi: random reachable
poses answered 422 ``unreachable``). ``ik_one``, the single-solution ``ik``, then tries harder; a
pose ``ik_all`` solves costs nothing more, so the Cartesian walks and the analytic arms keep their
speed:

- 7R arms whose held joint EAIK solves (the Panda) and the request does not fix: EAIK at
  ``HELD_VALUES`` values of that joint spread over its limits (one turn), nearest the seed's value
  first; the first value with a solution inside the limits (with ``configuration``) wins.
- Numeric arms: damped Newton with the redundant joints the request does not fix released, from
  the seed, home and ``RETRY_STARTS`` starts spread over the limits (a Latin hypercube from a fixed
  generator: the same request gets the same answer); the first verified solution inside the limits
  (with ``configuration``) wins.

6R arms with EAIK and the planar closed form are complete: no second effort, nor for a pose beyond
the arm's reach bound. The effort stops after ``RETRY_SECONDS`` or half of what is left of the
request's deadline, whichever comes first. Answers are verified like ``ik_all``'s (1e-9 m, 1e-9 rad).
"""

from __future__ import annotations

import math
import time

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from robots.ik import (
    POLISH_BELOW,
    IKSolutions,
    _dedupe,
    _turns,
    _verified,
    ik_all,
    solutions,
)
from robots.ik_robot import IKRobot as Robot

TWO_PI = 2.0 * math.pi
HELD_VALUES = 128
"""Values of an analytic 7R arm's held joint tried, over one turn of its range."""
RETRY_STARTS = 40
"""Starts of the released numeric search, besides the seed and home."""
RETRY_SECONDS = 1.0
"""[s]: longest second effort of one call (less when the request's deadline is nearer)."""


def ik_one(
    robot: Robot,
    T_base_tool: np.ndarray,
    seed: np.ndarray | None = None,
    fixed_joints: dict[str, float] | None = None,
    configuration: str | None = None,
    deadline: Deadline = NO_DEADLINE,
) -> IKSolutions:
    """``ik_all(robot, T_base_tool, seed, fixed_joints)``; when none of its solutions has
    ``configuration`` (any, when None), the second effort of the module docstring. Returns its
    solutions when it finds one, else ``ik_all``'s answer (which says why: labels, limits)."""
    fixed_joints = dict(fixed_joints or {})
    found = ik_all(robot, T_base_tool, seed, fixed_joints)
    if _matching(found, configuration) or not _incomplete(robot, fixed_joints):
        return found
    T = np.asarray(T_base_tool, dtype=float)
    seed = robot.home if seed is None else np.asarray(seed, dtype=float)
    if robot.reach_distance(T) > robot.reach_bound() + 1e-9:
        return found
    stop = time.monotonic() + min(RETRY_SECONDS, 0.5 * deadline.remaining())
    fixed = {robot.joint_names.index(n): float(v) for n, v in fixed_joints.items()}
    analytic = robot.analytic_ik
    if analytic is not None:
        better = _held_sweep(robot, T, seed, analytic, configuration, stop)
    else:
        better = _released(robot, T, seed, fixed, configuration, stop)
    return better if better is not None else found


def _matching(found: IKSolutions, configuration: str | None) -> bool:
    return any(configuration is None or c == configuration for c in found.configurations)


def _incomplete(robot: Robot, fixed_joints: dict[str, float]) -> bool:
    """Whether ``ik_all`` may have missed solutions: not for EAIK's 6R arms, the planar closed
    form, or a 7R arm whose held joint the request fixes (EAIK is complete at that value)."""
    analytic = robot.analytic_ik
    if analytic is not None:
        return analytic.held is not None and robot.joint_names[analytic.held] not in fixed_joints
    return robot.planar_closed_form is None


def _held_sweep(
    robot: Robot, T: np.ndarray, seed: np.ndarray, analytic, configuration: str | None, stop: float
) -> IKSolutions | None:
    j = analytic.held
    lo, hi = robot.position_limits[j]
    if hi - lo > TWO_PI:  # one turn, centred on the seed's value where the range allows
        lo = min(max(seed[j] - math.pi, lo), hi - TWO_PI)
        hi = lo + TWO_PI
    values = np.linspace(lo, hi, HELD_VALUES)
    for value in values[np.argsort(np.abs(values - seed[j]), kind="stable")]:
        if time.monotonic() > stop:
            break
        try:
            Q = analytic.solve(T, float(value))
        except (RuntimeError, ValueError):  # EAIK knows no decomposition at this value
            continue
        answer = _answer(robot, T, seed, Q, {j: float(value)}, "analytic", configuration)
        if answer is not None:
            return answer
    return None


def _released(
    robot: Robot,
    T: np.ndarray,
    seed: np.ndarray,
    fixed: dict[int, float],
    configuration: str | None,
    stop: float,
) -> IKSolutions | None:
    lower, upper = robot.position_limits[:, 0].copy(), robot.position_limits[:, 1].copy()
    for j, v in fixed.items():
        lower[j] = upper[j] = v
    lo, hi = np.maximum(lower, -math.pi), np.minimum(upper, math.pi)
    lo, hi = np.where(lo <= hi, lo, lower), np.where(lo <= hi, hi, upper)
    rng = np.random.default_rng(1)
    n, dof = RETRY_STARTS, robot.dof
    cells = rng.permuted(np.tile(np.arange(n), (dof, 1)), axis=1).T  # one start per stratum
    starts = np.vstack([seed, robot.home, lo + (cells + rng.random((n, dof))) / n * (hi - lo)])
    for j, v in fixed.items():
        starts[:, j] = v
    limits = (lower, upper, robot.revolute)
    for start in starts:
        if time.monotonic() > stop:
            break
        r = robot.ik_from(T, start, limits, max_iterations=100, tolerance=1e-11)
        if r.position_error <= POLISH_BELOW and r.orientation_error <= POLISH_BELOW:
            answer = _answer(robot, T, seed, r.positions[None], fixed, "numeric", configuration)
            if answer is not None:
                return answer
    return None


def _answer(
    robot: Robot,
    T: np.ndarray,
    seed: np.ndarray,
    Q: np.ndarray,
    held: dict[int, float],
    solver: str,
    configuration: str | None,
) -> IKSolutions | None:
    """The verified candidates of ``Q`` inside the limits as ``IKSolutions``, or None when none
    (with ``configuration``) remains."""
    Q = _dedupe(_verified(robot, T, Q, held), robot.revolute)
    Q = _turns(Q, seed, robot.position_limits, robot.revolute, False)
    if not len(Q):
        return None
    answer = solutions(robot, T, Q, seed, solver)
    return answer if _matching(answer, configuration) else None
