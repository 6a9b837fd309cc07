"""The Cartesian problem and its answer: ``CartesianTask`` (frozen input) and ``CartesianResult``
(frozen output carrying every diagnostic the response shows).

Every method (``core.cartesian.methods.METHODS``) takes a ``CartesianTask`` and returns a
``CartesianResult`` that ``core.cartesian.check.finish`` has checked and measured.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.measure import DeviationReport
from core.collisions import ClearanceReport
from core.errors import PlanningError
from core.kinematics import Clearance, Dynamics, Kinematics
from core.path import Path, build_path
from core.timing import DEFAULT_LAW
from core.timing.path_constraints import Effort
from core.trajectory import Trajectory

MAX_TICKS = 1_000_000
"""Most control ticks one resolved-rate run may simulate (bounds memory and time; ``TooLarge``
beyond)."""
DEFAULT_MAX_LINEAR_SPEED = 0.25
"""Tool speed [m/s] used when a request gives neither a duration nor speed limits."""
DEFAULT_MAX_ANGULAR_SPEED = 1.0
"""Tool angular speed [rad/s] used when a request gives neither a duration nor speed limits."""


@dataclass(frozen=True)
class PathSpec:
    """The shape of the tool path (``core.path.PATHS``): ``kind`` ``"line"`` (default) or
    ``"circ"`` with exactly one of ``interim`` / ``center`` (3,) [m] in the base frame."""

    kind: str = "line"
    interim: np.ndarray | None = None
    center: np.ndarray | None = None


@dataclass(frozen=True)
class CartesianTask:
    """Move the tool on the path (``path``: line by default) from FK(q_start) to T_goal.

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
        allow_violations: Return a plan that leaves the tolerance between its returned points or
            exceeds a joint acceleration limit (with warnings) instead of failing.
        solver: QP solver name for ``resolved_rate_dls``.
        deadline: Wall-time budget.
        path: The path shape (``PathSpec``; default the straight line).
        speed_profile: The timing law, a name in ``core.timing.TIMING_LAWS`` (``"trapezoidal"``:
            the speed-limited trapezoid, or the quintic for a fixed duration; ``"s_curve"``:
            continuous s'', path jerk limited).
        max_linear_jerk: Tool jerk limit [m/s^3] of the s-curve (None: its default).
        max_angular_jerk: Tool angular jerk limit [rad/s^3] of the s-curve (None: its default).
        max_linear_acceleration: Tool acceleration limit [m/s^2] (None: 1 m/s^2).
        max_angular_acceleration: Tool angular acceleration limit [rad/s^2] (None: 2 rad/s^2).
        clearance: The environment's distances (obstacles, self-collision), for the methods that
            avoid collisions (``bounded_deviation_nlp``, ``resolved_rate_dls``); None: no avoidance.
        collision_check: The collision object every answer is checked with (``core.collisions``:
            the start before planning, then the returned motion, continuously); the same object as
            ``clearance`` when the request has an environment, else the robot's self pairs only.
            None: nothing to check.
        keep_configuration: The trajectory keeps the start's configuration label (default). False
            lets the rate controllers pass a wrist singularity (the label changes, reported in
            ``diagnostics["configuration_changes"]``); the other methods follow one IK branch
            anyway.
        effort: Effort limits with the robot's dynamics (``core.cartesian.effort``: the plan is
            slowed until they hold; not with ``duration``), or None.
        dynamics: The robot's dynamics, for ``peak_effort`` (None: none known).
        gravity: Gravity ``(3,)`` [m/s^2] in the base frame for ``peak_effort`` (None: default).
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
    allow_violations: bool = False
    solver: str = "osqp"
    deadline: Deadline = NO_DEADLINE
    path: PathSpec = PathSpec()
    speed_profile: str = DEFAULT_LAW
    max_linear_jerk: float | None = None
    max_angular_jerk: float | None = None
    max_linear_acceleration: float | None = None
    max_angular_acceleration: float | None = None
    clearance: Clearance | None = None
    collision_check: Clearance | None = None
    keep_configuration: bool = True
    effort: Effort | None = None
    dynamics: Dynamics | None = None
    gravity: np.ndarray | None = None

    def line(self) -> Path:
        """The path from FK(q_start) to T_goal (the straight line unless ``path`` says otherwise);
        ``InputError`` at ``path.*`` for bad circle geometry."""
        return build_path(
            self.path.kind,
            self.robot.fk(self.q_start),
            self.T_goal,
            self.robot.task_space,
            interim=self.path.interim,
            center=self.path.center,
            field=("path",),
        )

    def prefix(self, end: float) -> CartesianTask:
        """The task of the path cut at ``end`` in (0, 1], re-parameterized over [0, 1]: the goal is
        the pose at ``end``; a shape given by a circle keeps it (its interim point becomes the
        point at ``end / 2``, so the same arc of the same circle is followed)."""
        path = self.line()
        T_end = path.pose(end)
        spec = self.path
        if spec.interim is not None or spec.center is not None:
            spec = PathSpec(spec.kind, interim=path.pose(0.5 * end)[:3, 3].copy())
        return replace(self, T_goal=T_end, path=spec)

    def speeds(self) -> tuple[float | None, float | None]:
        """Tool speed limits [m/s], [rad/s], with the defaults when nothing times the motion."""
        if (
            self.duration is None
            and self.max_linear_speed is None
            and self.max_angular_speed is None
        ):
            return DEFAULT_MAX_LINEAR_SPEED, DEFAULT_MAX_ANGULAR_SPEED
        return self.max_linear_speed, self.max_angular_speed


@dataclass(frozen=True)
class CartesianResult:
    """What a Cartesian method returns (frozen: a later stage builds a new one with ``replace``).

    Attributes:
        trajectory: The returned joint trajectory.
        fraction: Share of the line planned, in [0, 1] (< 1 only with ``allow_partial``).
        deviation: Dense deviation of ``trajectory`` from the line (set by ``finish``).
        min_singular_value: Smallest singular value of the task Jacobian met (set by ``finish``).
        singular_values: Smallest singular value of the task Jacobian at each returned point
            ``(N,)`` (set by ``finish``; the response's ``singular_value_profile``).
        warnings: Things the client should know (slow-downs, damping, clipping).
        knots: Knots of the bounded-deviation methods: ``s`` (K,), ``times`` (K,), ``positions``
            (K, dof); None for the others.
        diagnostics: Method-specific figures (JSON-serializable).
        failure: The error that ended a partial plan.
        clearance: How close the returned motion comes to contact (``core.collisions``), None when
            nothing is checked.
    """

    trajectory: Trajectory
    fraction: float = 1.0
    deviation: DeviationReport | None = None
    min_singular_value: float = float("nan")
    singular_values: np.ndarray | None = None
    warnings: tuple[str, ...] = ()
    knots: dict[str, np.ndarray] | None = None
    diagnostics: dict[str, Any] = field(default_factory=dict)
    failure: PlanningError | None = None
    clearance: ClearanceReport | None = None
