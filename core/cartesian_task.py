"""A Cartesian straight-line task, its result, and the dispatch to the five methods.

Every Cartesian method (``sampled``, ``bounded_deviation``, ``bounded_deviation_nlp``,
``resolved_rate``, ``resolved_rate_dls``) takes a ``CartesianTask`` and returns a ``CartesianResult``;
``finish`` gives every result the same independent checks and measurements (joint position and
velocity limits, dense deviation from the line, smallest singular value), so methods are compared on
equal terms and no method returns a trajectory that was not checked.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.deviation import DeviationReport, measure_deviation
from core.errors import InputError, JointLimit, JointRateLimit
from core.kinematics import Kinematics, jacobians, task_rows
from core.path.line import StraightLine
from core.trajectory import Trajectory

DEFAULT_MAX_LINEAR_SPEED = 0.25
"""Tool speed [m/s] used when a request gives neither a duration nor speed limits."""
DEFAULT_MAX_ANGULAR_SPEED = 1.0
"""Tool angular speed [rad/s] used when a request gives neither a duration nor speed limits."""
LIMIT_SLACK = 1e-9
"""Relative slack on joint limits when a returned trajectory is checked (rounding only)."""
MEASURE_CHUNK = 2048
"""Returned points measured between two deadline checks (about 0.25 s of work on a 2-core box)."""

METHODS = (
    "sampled",
    "bounded_deviation",
    "bounded_deviation_nlp",
    "resolved_rate",
    "resolved_rate_dls",
)


@dataclass(frozen=True)
class CartesianTask:
    """Move the tool on the straight line from FK(q_start) to T_goal.

    Attributes:
        robot: Kinematics of the arm.
        q_start: Start joint positions ``(dof,)``.
        T_goal: Goal tool pose ``T_base_tool`` (4, 4).
        q_goal: Goal joint positions when the request gave them (a hint for the end branch).
        position_tolerance: Allowed deviation from the line [m].
        orientation_tolerance: Allowed orientation deviation [rad].
        duration: Fixed duration [s], or None to time from speed limits.
        max_linear_speed: Tool speed limit [m/s] (None: default when no duration either).
        max_angular_speed: Tool angular speed limit [rad/s].
        sample_period: Spacing of returned points [s], or None.
        samples: Number of returned points, or None.
        control_period: Control tick [s] of the rate methods.
        allow_partial: Return the planned prefix (fraction < 1) instead of failing.
        solver: QP solver name for ``resolved_rate_dls``.
        deadline: Wall-time budget.
    """

    robot: Kinematics
    q_start: np.ndarray
    T_goal: np.ndarray
    q_goal: np.ndarray | None = None
    position_tolerance: float = 1e-3
    orientation_tolerance: float = 1e-2
    duration: float | None = None
    max_linear_speed: float | None = None
    max_angular_speed: float | None = None
    sample_period: float | None = None
    samples: int | None = None
    control_period: float = 1e-3
    allow_partial: bool = False
    solver: str = "osqp"
    deadline: Deadline = NO_DEADLINE

    def line(self) -> StraightLine:
        """The straight line from FK(q_start) to T_goal."""
        return StraightLine(self.robot.fk(self.q_start), self.T_goal, self.robot.task_space)

    def speeds(self) -> tuple[float | None, float | None]:
        """Tool speed limits [m/s], [rad/s], with the defaults when nothing times the motion."""
        if (
            self.duration is None
            and self.max_linear_speed is None
            and self.max_angular_speed is None
        ):
            return DEFAULT_MAX_LINEAR_SPEED, DEFAULT_MAX_ANGULAR_SPEED
        return self.max_linear_speed, self.max_angular_speed


@dataclass
class CartesianResult:
    """What a Cartesian method returns.

    Attributes:
        trajectory: The returned joint trajectory.
        fraction: Share of the line planned, in [0, 1] (< 1 only with ``allow_partial``).
        deviation: Dense deviation of ``trajectory`` from the line (set by ``finish``).
        min_singular_value: Smallest singular value of the task Jacobian met (set by ``finish``).
        warnings: Things the client should know (slow-downs, damping, clipping).
        knots: Knots of the bounded-deviation methods: ``s`` (K,), ``times`` (K,), ``positions``
            (K, dof); None for the others.
        diagnostics: Method-specific figures (JSON-serializable).
        failure: The error that ended a partial plan.
    """

    trajectory: Trajectory
    fraction: float = 1.0
    deviation: DeviationReport | None = None
    min_singular_value: float = float("nan")
    warnings: list[str] = field(default_factory=list)
    knots: dict[str, np.ndarray] | None = None
    diagnostics: dict[str, Any] = field(default_factory=dict)
    failure: Exception | None = None


def min_singular_values(
    robot: Kinematics, positions: np.ndarray, deadline: Deadline = NO_DEADLINE
) -> np.ndarray:
    """Smallest singular value of the task rows of the Jacobian at each row of ``positions``
    (``deadline`` checked every ``MEASURE_CHUNK`` rows)."""
    rows = task_rows(robot.task_space)
    out = []
    for i in range(0, len(positions), MEASURE_CHUNK):
        deadline.check("singular values along the trajectory")
        J = jacobians(robot, positions[i : i + MEASURE_CHUNK])[:, rows]
        out.append(np.linalg.svd(J, compute_uv=False)[:, -1])
    return np.concatenate(out)


def measure(task: CartesianTask, traj: Trajectory) -> DeviationReport:
    """``measure_deviation`` of ``traj`` against ``task.line()``, ``MEASURE_CHUNK`` points at a time
    with ``task.deadline`` checked between chunks, so a 100,000-point plan (2.2 million checks)
    honors the wall-time budget. Every check depends only on its own interval, so the chunks put
    together give the report of one call (to rounding, 1e-16 m at a chunk's last interval)."""
    line, n = task.line(), len(traj.times)
    kwargs = {
        "position_tolerance": task.position_tolerance,
        "orientation_tolerance": task.orientation_tolerance,
    }
    parts = []
    for i in range(0, n - 1, MEASURE_CHUNK):
        task.deadline.check("dense deviation measurement")
        j = min(i + MEASURE_CHUNK, n - 1) + 1
        piece = Trajectory(
            traj.times[i:j],
            traj.positions[i:j],
            traj.velocities[i:j],
            traj.accelerations[i:j],
            traj.joint_names,
        )
        parts.append(measure_deviation(task.robot, line, piece, **kwargs))
    if len(parts) == 1:
        return parts[0]

    def joined(name: str) -> np.ndarray:  # each part's last check is the next part's first
        arrays = [getattr(p, name) for p in parts]
        return np.concatenate([a[:-1] for a in arrays[:-1]] + [arrays[-1]])

    return DeviationReport(
        max_position=max(p.max_position for p in parts),
        max_orientation=max(p.max_orientation for p in parts),
        segment_position=np.concatenate([p.segment_position for p in parts]),
        segment_orientation=np.concatenate([p.segment_orientation for p in parts]),
        times=joined("times"),
        s=joined("s"),
        position=joined("position"),
        orientation=joined("orientation"),
    )


def check_limits(robot: Kinematics, traj: Trajectory, s: np.ndarray | None = None) -> None:
    """Raise JointLimit / JointRateLimit when ``traj`` leaves the robot's position or speed limits.

    ``s`` (N,) gives the path parameter of each point, for the error's location.
    """
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    span = np.maximum(hi - lo, 1.0)
    over = (traj.positions < lo - LIMIT_SLACK * span) | (traj.positions > hi + LIMIT_SLACK * span)
    if over.any():
        i, j = np.argwhere(over)[0]
        raise JointLimit(
            f"joint {robot.joint_names[j]} leaves its position limits at point {i}",
            joint=int(j),
            sample=int(i),
            s=None if s is None else float(s[i]),
        )
    vmax = robot.velocity_limits * (1.0 + LIMIT_SLACK)
    fast = np.abs(traj.velocities) > vmax
    if fast.any():
        i, j = np.argwhere(fast)[0]
        raise JointRateLimit(
            f"joint {robot.joint_names[j]} exceeds its velocity limit at point {i}",
            joint=int(j),
            sample=int(i),
            s=None if s is None else float(s[i]),
        )


def finish(
    task: CartesianTask, result: CartesianResult, s: np.ndarray | None = None
) -> CartesianResult:
    """Check limits, measure the deviation densely and the smallest singular value; return result."""
    check_limits(task.robot, result.trajectory, s)
    result.deviation = measure(task, result.trajectory)
    sv = min_singular_values(task.robot, result.trajectory.positions, task.deadline)
    result.min_singular_value = float(sv.min())
    return result


def validated_line(task: CartesianTask) -> StraightLine:
    """The task's line after the entry checks every method shares (``InputError`` / ``JointLimit``
    naming the field): tolerances, duration and speeds finite and > 0; start and goal positions
    finite, one per joint and inside the joint limits; a goal pose other than the start pose."""
    robot = task.robot
    for where, value in (
        (("tolerance", "position"), task.position_tolerance),
        (("tolerance", "orientation"), task.orientation_tolerance),
        (("duration",), task.duration),
        (("max_linear_speed",), task.max_linear_speed),
        (("max_angular_speed",), task.max_angular_speed),
    ):
        if value is not None and not (np.isfinite(value) and value > 0.0):
            raise InputError(f"{'.'.join(where)} must be a finite number > 0", field=where)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    for name, q, s in (("start", task.q_start, 0.0), ("goal", task.q_goal, 1.0)):
        if q is None:
            continue
        if np.shape(q) != (robot.dof,) or not np.all(np.isfinite(q)):
            raise InputError(
                f"{name}.positions needs {robot.dof} finite values, one per joint",
                field=(name, "positions"),
            )
        if np.any(q < lo) or np.any(q > hi):
            j = int(np.argmax(np.maximum(lo - q, q - hi)))
            raise JointLimit(
                f"{name}.positions puts joint {robot.joint_names[j]} outside its limits",
                field=(name, "positions", j),
                s=s,
                joint=j,
            )
    line = task.line()
    if line.length < 1e-9 and line.angle < 1e-9:
        raise InputError(
            "the goal pose is the start pose: there is no line to plan", field=("goal",)
        )
    return line


Planner = Callable[[CartesianTask], CartesianResult]


def planner(method: str) -> Planner:
    """The planning function of ``method`` (imported lazily: each lives in its own module)."""
    if method == "sampled":
        from core.cartesian import plan_sampled

        return plan_sampled
    if method == "bounded_deviation":
        from core.deviation import plan_bounded_deviation

        return plan_bounded_deviation
    if method == "bounded_deviation_nlp":
        from core.deviation_nlp import plan_bounded_deviation_nlp

        return plan_bounded_deviation_nlp
    if method == "resolved_rate":
        from core.rate_control import plan_resolved_rate

        return plan_resolved_rate
    if method == "resolved_rate_dls":
        from core.rate_control import plan_resolved_rate_dls

        return plan_resolved_rate_dls
    raise InputError(
        f"method must be one of {', '.join(METHODS)}",
        field=("method",),
        extra={"methods": list(METHODS)},
    )


def plan(task: CartesianTask, method: str) -> CartesianResult:
    """Plan ``task`` with ``method``; a result its planner did not ``finish`` is finished here."""
    result = planner(method)(task)
    return result if result.deviation is not None else finish(task, result)
