"""The segments of a motion program (PTP, LIN, CIRC) and the program task, as frozen inputs.

Every segment starts where the previous one ended. Units: meters, radians, seconds; poses are
``T_base_tool`` (4, 4).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.cartesian.task import DEFAULT_MAX_ANGULAR_SPEED, DEFAULT_MAX_LINEAR_SPEED
from core.joint.profiles import PROFILES
from core.kinematics import Clearance, Dynamics, Kinematics
from core.motion.clearance import GroupClearance
from core.timing import DEFAULT_LAW, PROGRAM_DEFAULT
from core.timing.path_constraints import Effort
from core.timing.s_curve import DEFAULT_ANGULAR_JERK, DEFAULT_LINEAR_JERK
from core.timing.speed_limited import DEFAULT_ANGULAR_ACCELERATION, DEFAULT_LINEAR_ACCELERATION

SegmentType = Literal["ptp", "lin", "circ"]
MAX_SEGMENTS = 100


def ptp_profile(name: str) -> bool:
    """Whether a PTP between stops may take the joint profile ``name``: a key of
    ``core.joint.profiles.PROFILES`` held to acceleration limits (every one but ``linear``)."""
    kind = PROFILES.get(name)
    return kind is not None and "acceleration" in kind.rated


@dataclass(frozen=True)
class Segment:
    """One move of a program.

    Attributes:
        type: ``"ptp"`` (joint space), ``"lin"`` (straight line) or ``"circ"`` (circle arc).
        goal_pose: Goal tool pose (4, 4), or None when ``goal_positions`` is given.
        goal_positions: Goal joint positions (dof,) [rad or m]; for lin/circ their FK is the goal pose.
        configuration: PTP to a pose: the configuration label the IK solution must carry.
        profile: PTP between stops (not blended at either end): the joint profile of
            ``core.joint.profiles.PROFILES`` it is timed with (``trapezoidal``, ``quintic``,
            ``jerk_limited``), under the joint limits times its scales. None, or a PTP inside a
            blend: the program's timing of its stretch between stops.
        interim: CIRC: a point (3,) [m] on the arc.
        center: CIRC: the circle's centre (3,) [m].
        blend_radius: Radius [m] of the blend sphere about this segment's goal position (0: stop).
        velocity_scale: Share (0, 1] of the joint velocity limits this segment may use.
        acceleration_scale: Share (0, 1] of the joint acceleration limits.
        max_linear_speed: LIN/CIRC tool speed limit [m/s] (None: ``DEFAULT_MAX_LINEAR_SPEED``).
        max_angular_speed: LIN/CIRC tool angular speed limit [rad/s].
        speed_profile: LIN/CIRC: a ``core.timing.TIMING_LAWS`` name: ``"trapezoidal"`` (the
            default: the program's common timing) or ``"s_curve"``: the stretch between stops
            holding this segment is timed as one S-curve (continuous path acceleration, path jerk
            limited by the tool jerk limits).
        max_linear_jerk: S-curve tool jerk limit [m/s^3] (None: ``DEFAULT_LINEAR_JERK``).
        max_angular_jerk: S-curve tool angular jerk limit [rad/s^3] (None: ``DEFAULT_ANGULAR_JERK``).
        max_linear_acceleration: LIN/CIRC tool acceleration limit [m/s^2] (None: 1).
        max_angular_acceleration: LIN/CIRC tool angular acceleration limit [rad/s^2] (None: 2).
        position_tolerance: LIN/CIRC allowed deviation from the path [m].
        orientation_tolerance: LIN/CIRC allowed orientation deviation [rad].
        method: LIN/CIRC: the ``core.cartesian.methods.METHODS`` entry that plans the segment's
            joint path on its line or arc (``core.program.build``).
        planner: PTP: ``"collision_free"``: its joint motion is found around the environment's
            obstacles (``core.program.ptp_planned``); None: the straight joint segment.
    """

    type: SegmentType
    goal_pose: np.ndarray | None = None
    goal_positions: np.ndarray | None = None
    configuration: str | None = None
    profile: str | None = None
    interim: np.ndarray | None = None
    center: np.ndarray | None = None
    blend_radius: float = 0.0
    velocity_scale: float = 1.0
    acceleration_scale: float = 1.0
    max_linear_speed: float | None = None
    max_angular_speed: float | None = None
    speed_profile: str = DEFAULT_LAW
    max_linear_jerk: float | None = None
    max_angular_jerk: float | None = None
    max_linear_acceleration: float | None = None
    max_angular_acceleration: float | None = None
    position_tolerance: float = 1e-3
    orientation_tolerance: float = 1e-2
    method: str = "sampled"
    planner: str | None = None

    def tool_jerks(self) -> tuple[float, float]:
        """S-curve tool jerk limits [m/s^3], [rad/s^3] (defaults where not given)."""
        lin = DEFAULT_LINEAR_JERK if self.max_linear_jerk is None else self.max_linear_jerk
        ang = DEFAULT_ANGULAR_JERK if self.max_angular_jerk is None else self.max_angular_jerk
        return lin, ang

    @property
    def cartesian(self) -> bool:
        return self.type != "ptp"

    def tool_accelerations(self) -> tuple[float, float]:
        """Tool acceleration limits [m/s^2], [rad/s^2] of a LIN/CIRC segment (inf for PTP)."""
        if not self.cartesian:
            return np.inf, np.inf
        lin, ang = self.max_linear_acceleration, self.max_angular_acceleration
        return (
            DEFAULT_LINEAR_ACCELERATION if lin is None else float(lin),
            DEFAULT_ANGULAR_ACCELERATION if ang is None else float(ang),
        )

    def tool_speeds(self) -> tuple[float, float]:
        """Tool speed limits [m/s], [rad/s] of a LIN/CIRC segment (inf for PTP)."""
        if not self.cartesian:
            return np.inf, np.inf
        if self.max_linear_speed is None and self.max_angular_speed is None:
            return DEFAULT_MAX_LINEAR_SPEED, DEFAULT_MAX_ANGULAR_SPEED
        lin = np.inf if self.max_linear_speed is None else self.max_linear_speed
        ang = np.inf if self.max_angular_speed is None else self.max_angular_speed
        return lin, ang


@dataclass(frozen=True)
class ProgramTask:
    """A motion program: segments from ``q_start``, timed as one trajectory.

    Attributes:
        robot: Kinematics of the arm.
        q_start: Start joint positions (dof,).
        segments: The moves, in order (1 to ``MAX_SEGMENTS``).
        sample_period: Spacing of returned points [s], or None.
        samples: Number of regularly spaced returned points (segment goals and blend window
            boundaries are added to them), or None.
        allow_partial: Return the program up to a failing segment instead of failing.
        deadline: Wall-time budget.
        collision_check: The collision object the program is checked with (``core.collisions``:
            the start and every goal given as joints before planning, then the whole motion
            continuously), None: nothing to check.
        timing: The ``core.timing.TIMING_LAWS`` law of the stretches between stops whose LIN/CIRC
            segments ask for no other (``s_curve``), one of ``JOINT_PATH_LAWS``:
            ``"time_optimal"`` (``PROGRAM_DEFAULT``) or ``"jerk_limited"``.
        effort: Effort limits with the robot's dynamics (``core.program.effort``), or None.
        dynamics: The robot's dynamics, for ``peak_effort`` (None: none known).
        gravity: Gravity ``(3,)`` [m/s^2] in the base frame for ``peak_effort`` (None: default).
        seed: Seed of the collision-free planner of PTP segments (integer >= 0).
        planner_clearance: The environment's clearance for that planner
            (``core.motion.clearance.GroupClearance``), None: no environment (a PTP stays
            straight).
    """

    robot: Kinematics
    q_start: np.ndarray
    segments: tuple[Segment, ...]
    sample_period: float | None = None
    samples: int | None = None
    allow_partial: bool = False
    deadline: Deadline = NO_DEADLINE
    collision_check: Clearance | None = None
    timing: str = PROGRAM_DEFAULT
    effort: Effort | None = None
    dynamics: Dynamics | None = None
    gravity: np.ndarray | None = None
    seed: int = 0
    planner_clearance: GroupClearance | None = None
