"""Cartesian requests -> ``CartesianTask``, and ``CartesianResult`` -> response bodies.

Shared by ``POST /v1/trajectories/cartesian`` and ``POST /v1/compare``: ``task_from_spec`` builds the
task once from the method-independent part of a request; ``run`` plans it with one method;
``diagnostics`` and ``result_body`` only format what the core result carries (every method the same
diagnostics (the API's ``fraction``,
``max_position_deviation``, ``max_orientation_deviation``, ``min_singular_value``, ``knot_count``;
``failure`` for a partial plan; small ``deviation_profile`` and ``singular_value_profile`` arrays for
plotting) and the top-level ``knots`` of the bounded-deviation methods.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from core.budget import Deadline
from core.cartesian.plan import plan
from core.cartesian.task import CartesianResult, CartesianTask, PathSpec
from core.errors import InputError, PlanningError, TooLarge
from core.kinematics import Kinematics
from core.trajectory import MAX_POINTS
from service.convert.dynamics import dynamics_of, effort_inputs, gravity_of
from service.convert.environment import clearance_diagnostics, collision_check, inline_urdf
from service.convert.robot import robot_positions
from service.encoding import base_diagnostics, check_finite, ros_durations, trajectory_body
from service.errors import planning_error_body
from service.schemas.cartesian import CartesianTaskSpec

_SAME_NAMED = tuple(
    sorted(
        {f.name for f in dataclasses.fields(CartesianTask)}
        & set(CartesianTaskSpec.model_fields)
        - {"robot", "path", "gravity"}  # the request names the robot (the task holds the
        # resolved model); the path shape becomes a ``PathSpec``; gravity an array
    )
)
"""Request fields passed to ``CartesianTask`` as they are (same name, same units): the timing,
sampling, control and partial-plan options. A field added to both is passed on with no edit here."""

PROFILE_POINTS = 256
"""Most points of each plotting profile in the diagnostics."""


def _joint_positions(robot: Kinematics, values: list[float], where: str) -> np.ndarray:
    """Positions of ``where`` (``"start"`` or ``"goal"``): ``robot_positions``, a failure at ``s``
    0 (start) or 1 (goal)."""
    return robot_positions(robot, values, (where, "positions"), s=0.0 if where == "start" else 1.0)


def task_from_spec(
    spec: CartesianTaskSpec,
    robot: Kinematics,
    deadline: Deadline,
    max_points: int = MAX_POINTS,
    environment_field: tuple[str | int, ...] = ("environment",),
) -> CartesianTask:
    """The core task of a request (any method): lengths and limits of the joint positions checked.

    Args:
        spec: The request (``CartesianRequest`` or compare's ``task``).
        robot: The resolved robot (``robots.registry.resolve(spec.robot)``).
        deadline: Wall-time budget of the planning.
        max_points: Most points of a response (``samples`` over it is 422 ``too_large``).
        environment_field: Where ``spec.environment`` sits in the request (validation errors).
    """
    q_start = _joint_positions(robot, spec.start.positions, "start")
    q_goal = None
    if spec.goal.positions is not None:
        q_goal = _joint_positions(robot, spec.goal.positions, "goal")
        T_goal = robot.fk(q_goal)
    elif spec.goal.pose is not None:
        T_goal = spec.goal.pose.as_matrix()
    else:
        raise InputError("give exactly one of goal.pose or goal.positions", field=("goal",))
    if spec.samples is not None and spec.samples > max_points:
        raise TooLarge(
            f"samples={spec.samples} exceeds the limit of {max_points} points", field=("samples",)
        )
    same_named = {name: getattr(spec, name) for name in _SAME_NAMED}
    # The request's one collision object: every answer is checked with it; the methods that avoid
    # obstacles plan around it when the request has an environment.
    check = collision_check(robot, spec.environment, inline_urdf(spec.robot), environment_field)  # type: ignore[arg-type]
    shape = spec.path
    path = PathSpec(
        kind=shape.type,
        interim=None if shape.interim is None else np.asarray(shape.interim, dtype=float),
        center=None if shape.center is None else np.asarray(shape.center, dtype=float),
    )
    task = CartesianTask(
        path=path,
        robot=robot,
        q_start=q_start,
        T_goal=T_goal,
        q_goal=q_goal,
        position_tolerance=spec.tolerance.position,
        orientation_tolerance=spec.tolerance.orientation,
        deadline=deadline,
        clearance=None if spec.environment is None else check,
        collision_check=check,
        effort=effort_inputs(spec, robot, robot.dof),  # type: ignore[arg-type]
        dynamics=dynamics_of(robot),  # type: ignore[arg-type]
        gravity=gravity_of(spec, robot),  # type: ignore[arg-type]
        **same_named,
    )
    task.line()  # bad circle geometry: 422 validation at path.* before any method runs
    return task


def run(
    task: CartesianTask, method: str, max_points: int = MAX_POINTS
) -> tuple[CartesianResult, float]:
    """Plan ``task`` with ``method``: the result (checked finite and within ``max_points``) and the
    planning time [ms]. Raises the method's ``PlanningError``."""
    started = time.perf_counter()
    result = plan(task, method)
    elapsed_ms = (time.perf_counter() - started) * 1e3
    check_finite(result.trajectory)
    n = len(result.trajectory.times)
    if n > max_points:
        raise TooLarge(
            f"the plan has {n} points, over the limit of {max_points}; give a larger sample_period",
            field=("sample_period",),
        )
    return result, elapsed_ms


def failure_body(err: BaseException) -> dict[str, Any]:
    """The problem body (``code``, ``title``, ``detail``, ``s`` and the error's own fields, such as a
    collision's ``links``, ``distance`` and ``time_from_start``) of the error that ended a partial
    plan: what the 422 would have said without ``allow_partial``."""
    if isinstance(err, PlanningError):
        return planning_error_body(err)[1]
    return {"code": "infeasible", "title": "Planning failed", "s": None, "detail": str(err)}


def diagnostics(
    result: CartesianResult,
    method: str,
    compute_time_ms: float,
    unchecked: tuple[str, ...] = (),
) -> dict[str, Any]:
    """The diagnostics of a Cartesian plan (every method alike; see the module docstring);
    ``unchecked``: what the collision check could not see (``unchecked_warnings``)."""
    traj = result.trajectory
    diag = base_diagnostics(traj, method, compute_time_ms)
    diag["warnings"] = [*result.warnings, *unchecked]
    dev = result.deviation
    diag["fraction"] = float(result.fraction)
    diag["max_position_deviation"] = None if dev is None else _finite(dev.max_position)
    diag["max_orientation_deviation"] = None if dev is None else _finite(dev.max_orientation)
    diag["min_singular_value"] = _finite(result.min_singular_value)
    if result.knots is not None:
        diag["knot_count"] = len(result.knots["s"])
    if result.failure is not None:
        diag["failure"] = failure_body(result.failure)
    diag.update(clearance_diagnostics(result.clearance, unchecked))
    for key, value in result.diagnostics.items():
        diag.setdefault(key, value)
    if dev is not None:
        idx, edges = _bins(len(dev.times))
        diag["deviation_profile"] = {
            "time_from_start": dev.times[idx].tolist(),
            "s": dev.s[idx].tolist(),
            "position": np.maximum.reduceat(dev.position, edges).tolist(),
            "orientation": np.maximum.reduceat(dev.orientation, edges).tolist(),
        }
    if result.singular_values is not None:
        idx, _ = _bins(len(traj.times))
        diag["singular_value_profile"] = {
            "time_from_start": traj.times[idx].tolist(),
            "value": result.singular_values[idx].tolist(),
        }
    return diag


def knots_body(result: CartesianResult, time_format: str = "float") -> list[dict[str, Any]] | None:
    """``[{"s", "time_from_start", "positions"}]`` of a bounded-deviation result, else None."""
    if result.knots is None:
        return None
    times = np.asarray(result.knots["times"], dtype=float)
    stamps: list[Any] = ros_durations(times) if time_format == "ros" else times.tolist()
    return [
        {"s": float(s), "time_from_start": t, "positions": list(map(float, q))}
        for s, t, q in zip(result.knots["s"], stamps, result.knots["positions"], strict=True)
    ]


def result_body(
    result: CartesianResult,
    method: str,
    compute_time_ms: float,
    time_format: str = "float",
    unchecked: tuple[str, ...] = (),
) -> dict[str, Any]:
    """The response document: the trajectory, its diagnostics and (bounded deviation) ``knots``."""
    diag = diagnostics(result, method, compute_time_ms, unchecked)
    knots = knots_body(result, time_format)
    if knots is None:
        return trajectory_body(result.trajectory, diag, time_format)
    return trajectory_body(result.trajectory, diag, time_format, knots=knots)


def _bins(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Representative indices and bin starts of at most ``PROFILE_POINTS`` bins over ``n`` values
    (the last value gets its own bin so the profile ends at the end)."""
    if n <= PROFILE_POINTS:
        idx = np.arange(n)
        return idx, idx
    edges = np.unique(np.linspace(0, n - 1, PROFILE_POINTS).astype(int))
    return edges, edges


def _finite(value: float | None) -> float | None:
    if value is None:
        return None
    f = float(value)
    return f if math.isfinite(f) else None
