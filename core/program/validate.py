"""Checks of a program before planning: counts, scales, blend radii against segment lengths.

Every tool position at a segment end is known before any IK runs (a goal pose, or FK of goal
joints), so blend radii are checked first: a radius over half of either neighbour's length, or two
spheres on one segment that overlap (their radii add up to more than the distance between its
ends), is ``InputError`` at that segment's ``blend_radius``. Spheres about goals that are not the two
ends of one segment may overlap: a cycle through the same waypoints (pick A, place B, pick A)
blends at each visit, one blend at a time. Zero-length segments are skipped
(with a warning) and do not count as neighbours.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from core.errors import InputError
from core.joint.profiles import PROFILES
from core.path.line import pose_error
from core.program.geometry.paths import cartesian_path
from core.program.ptp_planned import PLANNERS
from core.program.segments import MAX_SEGMENTS, ProgramTask, ptp_profile
from core.timing import DEFAULT_LAW, JOINT_PATH_LAWS, TIMING_LAWS, program_law, speed_profile_law

ZERO_LENGTH = 1e-9
"""A segment moving the tool less than this [m] and [rad] (PTP: joints, [rad]) is skipped."""


@dataclass(frozen=True)
class Layout:
    """What the checks found.

    Attributes:
        goals: Goal tool pose of each segment (4, 4) (PTP to joints: their FK).
        lengths: Tool path length [m] of each segment (PTP: the chord).
        active: Indices of the segments that move (the others are skipped).
        blends: ``blends[i]``: blend radius [m] out of segment i (0 when it stops there).
        warnings: Skipped segments and ignored radii.
    """

    goals: tuple[np.ndarray, ...]
    lengths: tuple[float, ...]
    active: tuple[int, ...]
    blends: tuple[float, ...]
    warnings: tuple[str, ...]


def layout(task: ProgramTask) -> Layout:
    """Check ``task`` (see the module docstring) and lay its segments out."""
    robot, segs = task.robot, task.segments
    if not 1 <= len(segs) <= MAX_SEGMENTS:
        raise InputError(f"give 1 to {MAX_SEGMENTS} segments", field=("segments",))
    if not program_law(task.timing):
        raise InputError(
            f"timing must be one of {', '.join(sorted(JOINT_PATH_LAWS))}", field=("timing",)
        )
    if segs[-1].blend_radius > 0.0:
        raise InputError(
            "the last segment cannot blend (there is nothing to blend into)",
            field=("segments", len(segs) - 1, "blend_radius"),
        )
    T_prev = robot.fk(task.q_start)
    q_prev: np.ndarray | None = np.asarray(task.q_start, dtype=float)
    goals, lengths, active, warnings = [], [], [], []
    for i, seg in enumerate(segs):
        check_segment(task, i)
        if seg.goal_pose is not None:
            T_goal = np.asarray(seg.goal_pose, dtype=float)
        elif seg.goal_positions is not None:
            T_goal = robot.fk(seg.goal_positions)
        else:
            raise InputError("give goal.pose or goal.positions", field=("segments", i, "goal"))
        dp, dr = pose_error(T_prev, T_goal)
        if robot.task_space == "position_xy":  # only x and y count: a z or turn alone is no motion
            dp, dr = float(np.linalg.norm(T_goal[:2, 3] - T_prev[:2, 3])), 0.0
        length = dp
        if seg.type == "circ" and (dp >= ZERO_LENGTH or dr >= ZERO_LENGTH):
            length = cartesian_path(seg, T_prev, T_goal, robot.task_space, i).length
        elif seg.type == "circ":
            length = 0.0
        moves = dp >= ZERO_LENGTH or dr >= ZERO_LENGTH
        if seg.type == "ptp" and seg.goal_positions is not None:
            # Joints known so far (only PTPs to joints since the start): compare them too; else
            # another branch may reach the same pose: not skipped.
            q_goal = np.asarray(seg.goal_positions, dtype=float)
            moves = q_prev is None or bool(np.abs(q_goal - q_prev).max() >= ZERO_LENGTH)
            q_prev = q_goal
        else:
            q_prev = None
        if moves:
            active.append(i)
        else:
            warnings.append(f"segment {i} has zero length: skipped")
        goals.append(T_goal)
        lengths.append(float(length))
        T_prev = T_goal
    blends = blend_radii(task, active, lengths, goals)
    for i, seg in enumerate(segs):
        if seg.blend_radius > 0.0 and blends[i] == 0.0 and i != len(segs) - 1:
            warnings.append(f"segment {i}: blend_radius ignored (no moving segment to blend with)")
    return Layout(tuple(goals), tuple(lengths), tuple(active), tuple(blends), tuple(warnings))


def check_segment(task: ProgramTask, i: int) -> None:
    """The entry checks of segment ``i``: scales, timing law, tool limits, PTP profile."""
    seg, robot = task.segments[i], task.robot
    for name in ("velocity_scale", "acceleration_scale"):
        if not 0.0 < getattr(seg, name) <= 1.0:
            raise InputError(f"{name} must be in (0, 1]", field=("segments", i, name))
    if not speed_profile_law(seg.speed_profile) or (
        seg.speed_profile != DEFAULT_LAW and not seg.cartesian
    ):
        names = ", ".join(k for k in TIMING_LAWS if speed_profile_law(k))
        raise InputError(
            f"speed_profile must be one of {names} (LIN/CIRC segments)",
            field=("segments", i, "speed_profile"),
        )
    tool = ("max_linear_jerk", "max_angular_jerk", "max_linear_acceleration",
            "max_angular_acceleration")  # fmt: skip
    for name in tool:
        value = getattr(seg, name)
        if value is not None and not (np.isfinite(value) and value > 0.0):
            raise InputError(f"{name} must be > 0", field=("segments", i, name))
    if seg.planner is not None and (seg.type != "ptp" or seg.planner not in PLANNERS):
        raise InputError(
            f"planner must be one of {', '.join(PLANNERS)} (PTP segments only)",
            field=("segments", i, "planner"),
        )
    if seg.planner is not None and seg.profile is not None:
        raise InputError(
            "a PTP with a planner follows its planned path under the program's timing: give no "
            "profile",
            field=("segments", i, "profile"),
        )
    if seg.profile is None:
        return
    if seg.type != "ptp" or not ptp_profile(seg.profile):
        kinds = tuple(k for k in PROFILES if ptp_profile(k))
        raise InputError(
            f"profile must be one of {', '.join(kinds)} (PTP segments only)",
            field=("segments", i, "profile"),
        )
    if seg.profile == "jerk_limited" and robot.jerk_limits is None:
        raise InputError(
            f"the jerk_limited profile needs the robot's jerk limits; {robot.name} publishes none",
            field=("segments", i, "profile"),
        )


def blend_radii(
    task: ProgramTask, active: list[int], lengths: list[float], goals: list[np.ndarray]
) -> list[float]:
    """The blend radius out of each segment (0: it stops), checked against its neighbours'
    lengths and the other sphere of the next segment (see the module docstring)."""
    segs = task.segments
    blends = [0.0] * len(segs)
    for a, b in itertools.pairwise(active):
        r = segs[a].blend_radius
        if r <= 0.0:
            continue
        half = 0.5 * min(lengths[a], lengths[b])
        if r > half:
            raise InputError(
                f"blend_radius {r:.4g} m exceeds half of a neighbouring segment's length "
                f"({half:.4g} m)",
                field=("segments", a, "blend_radius"),
            )
        blends[a] = r
    for prev, b in itertools.pairwise(active):
        chord = float(np.linalg.norm(goals[b][:3, 3] - goals[prev][:3, 3]))
        if blends[prev] + blends[b] > chord + 1e-12:
            raise InputError(
                f"the blend spheres at both ends of segment {b} overlap",
                field=("segments", b, "blend_radius"),
            )
    return blends
