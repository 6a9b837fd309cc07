"""The request of ``POST /v1/trajectories/collision_free`` (API.md, "Collision-free motions").

Joint array lengths and position limits are checked against the robot in
``service/convert/collision_free.py``; ``max_planning_time`` against the request's time budget
there too (it is a setting of the service).
"""

from __future__ import annotations

from typing import Any, Literal, get_args

from pydantic import Field, model_validator

from core.motion.timing import TIMINGS
from service.schemas.common import (
    GRAVITY_FIELD,
    TOOL_FIELD,
    ConfigurationLabel,
    Gravity,
    JointPositions,
    Pose,
    RobotRef,
    Sampling,
    StrictModel,
    Tool,
)
from service.schemas.environment import Environment
from service.schemas.trajectories import JointLimitsIn

MAX_SEED = 2**31 - 1
"""Largest ``seed`` accepted."""
MAX_PLANNING_TIME = 1e5
"""[s] Largest ``max_planning_time`` the schema accepts (the request's time budget caps it)."""

Timing = Literal["time_optimal", "jerk_limited"]
if get_args(Timing) != TIMINGS:  # one list: core's
    raise ImportError("service.schemas.collision_free.Timing differs from core TIMINGS")


class CollisionFreeStart(StrictModel):
    positions: JointPositions = Field(
        description="Start joint positions [rad or m], one per joint, inside the limits."
    )


class CollisionFreeGoal(StrictModel):
    """Goal joint positions, or a tool pose (every IK solution tried, clear ones nearest first)."""

    positions: JointPositions | None = Field(default=None, description="Goal joints [rad or m].")
    pose: Pose | None = Field(default=None, description="Goal tool pose in the base frame.")
    configuration: ConfigurationLabel | None = Field(
        default=None,
        description="Configuration label the goal's IK solution must carry (with pose; robots "
        "that have labels). Without it every solution is a candidate. A label the pose has no "
        "solution with is 422 `unreachable` with `configurations` (the labels it has); a label "
        "the robot does not know is 422 `validation`.",
    )

    @model_validator(mode="after")
    def _one_of(self) -> Any:
        if (self.pose is None) == (self.positions is None):
            raise ValueError("give exactly one of goal.pose or goal.positions")
        if self.configuration is not None and self.pose is None:
            raise ValueError("configuration goes with goal.pose")
        return self


class CollisionFreeRequest(Sampling):
    """``POST /v1/trajectories/collision_free``: a joint motion that keeps the clearance."""

    robot: RobotRef = Field(description="A registered robot name or an inline URDF model.")
    tool: Tool | None = TOOL_FIELD
    start: CollisionFreeStart = Field(description="Where the motion starts (at rest).")
    goal: CollisionFreeGoal = Field(description="Where it ends (at rest).")
    environment: Environment | None = Field(
        default=None,
        description="Obstacles, clearance, self-collision, allowed pairs (API.md, Environment). "
        "Without it only the robot's own links are kept apart.",
    )
    limits: JointLimitsIn | None = Field(
        default=None,
        description="Per-joint velocity, acceleration (and, for jerk_limited, jerk) limits "
        "replacing the robot's, list by list; effort [N m or N] (robots with dynamics): the timed "
        "motion is slowed uniformly until the inverse-dynamics torque keeps it.",
    )
    gravity: Gravity | None = GRAVITY_FIELD
    timing: Timing = Field(
        default="time_optimal",
        description="time_optimal: the fastest timing of the blended path under the velocity and "
        "acceleration limits; jerk_limited: jerk-limited S-curves along the straight segments, "
        "at rest at each waypoint.",
    )
    seed: int = Field(
        default=0,
        ge=0,
        le=MAX_SEED,
        description="Seed of the sampling planner (0 to 2^31 - 1): the same request and seed "
        "give the same answer.",
    )
    max_planning_time: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_PLANNING_TIME,
        description="Longest search [s] (default and maximum: the request's time budget, "
        "TRAJ_TIME_BUDGET_S). No path found within it is 422 no_path_found.",
    )
