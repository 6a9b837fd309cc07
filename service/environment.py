"""The one collision check every trajectory route calls after planning.

``guard`` checks a returned trajectory continuously (``robots.collision``) against the request's
``environment`` and the robot's own links: a start or goal in collision is 422 ``collision`` saying
which; a contact on the way is 422 ``collision`` (time, ``s`` for Cartesian plans, the two names, the
distance), or with ``allow_partial`` the prefix before the contact. Diagnostics gain ``min_clearance``
[m], ``closest`` and ``clearance_profile`` (the smallest pair distance at up to ``PROFILE_POINTS``
returned points) whenever something is checked. Without ``environment``, robots with collision
geometry are still checked for self-collision.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from core.cartesian.check import finish
from core.cartesian.partial import MIN_FRACTION, partial_warning
from core.clearance import approach_text
from core.errors import Collision, InputError, PlanningError
from core.trajectory import Trajectory
from robots import registry
from robots.collision import CollisionChecker, Obstacle, PathCheck, robot_setup
from robots.model import Robot
from service.memo import collision_key, shared
from service.schemas.environment import Environment, Halfspace

PROFILE_POINTS = 200
"""Most returned points in a ``clearance_profile`` (evenly spread over the rows, ends included)."""


@dataclass(frozen=True)
class Guarded:
    """A checked trajectory: the whole one, or (``allow_partial``) the clear prefix.

    Attributes:
        trajectory: What to return.
        diagnostics: ``min_clearance``, ``closest``, ``clearance_profile`` (and
            ``collision_warnings``); empty when nothing was checked.
        failure: The contact that cut the trajectory, or None.
        fraction: Share of the duration returned (1 without a contact).
        warnings: What is not checked (mesh-only links; obstacles for a robot without collision
            geometry), for the answer's ``diagnostics.warnings``.
    """

    trajectory: Trajectory
    diagnostics: dict[str, Any]
    failure: Collision | None = None
    fraction: float = 1.0
    warnings: tuple[str, ...] = ()


def obstacles(env: Environment) -> list[Obstacle]:
    """The request's obstacles as ``robots.collision.Obstacle`` (base frame)."""
    out = []
    for o in env.obstacles:
        s = o.shape
        if isinstance(s, Halfspace):
            out.append(Obstacle(o.name, "halfspace", normal=tuple(s.normal), offset=s.offset))  # type: ignore[arg-type]
            continue
        T = np.eye(4) if o.pose is None else o.pose.as_matrix()
        out.append(
            Obstacle(
                o.name,
                s.type,
                size=tuple(getattr(s, "size", ())),
                radius=float(getattr(s, "radius", 0.0)),
                length=float(getattr(s, "length", 0.0)),
                T_base_obstacle=T,
            )
        )
    return out


def clearance_profile(check: CollisionChecker, trajectory: Trajectory) -> dict[str, list[float]]:
    """The smallest distance [m] over the checked pairs (negative: penetration) at up to
    ``PROFILE_POINTS`` returned points of ``trajectory``, evenly spread by index with both ends
    (every point when there are fewer): ``{"time_from_start": [s], "value": [m]}``."""
    n = len(trajectory.times)
    rows = np.unique(np.round(np.linspace(0, n - 1, min(n, PROFILE_POINTS))).astype(int))
    d = check.min_distances(trajectory.positions[rows])
    return {"time_from_start": trajectory.times[rows].tolist(), "value": d.tolist()}


@shared("collision_model", collision_key)
def checker(
    robot: Robot,
    env: Environment | None,
    urdf: str | None = None,
    field: tuple[str | int, ...] = ("environment",),
) -> CollisionChecker | None:
    """The collision checker of a request, or None when there is nothing to check.

    Raises ``InputError`` at the field for an obstacle named like a link and for names in
    ``allowed_collisions`` that are neither links nor obstacles.
    """
    geometry, allowed_self = robot_setup(robot, urdf)
    env = env or Environment()
    links = set(robot.frame_names())
    for i, o in enumerate(env.obstacles):
        if o.name in links:
            raise InputError(
                "an obstacle may not have the name of one of the robot's links",
                field=(*field, "obstacles", i, "name"),
            )
    names = links | {o.name for o in env.obstacles}
    for i, pair in enumerate(env.allowed_collisions):
        for j, name in enumerate(pair):
            if name not in names:
                raise InputError(
                    "allowed_collisions names a link or obstacle that does not exist",
                    field=(*field, "allowed_collisions", i, j),
                    extra={"links": sorted(links)},
                )
    if len(geometry.links) == 0:
        return None
    check = CollisionChecker(
        robot,
        geometry,
        obstacles(env),
        clearance=env.clearance,
        self_collision=env.self_collision,
        allowed=[(a, b) for a, b in env.allowed_collisions],
        allowed_self=allowed_self,
    )
    return check if check.n_pairs else None


def _clearance(result: PathCheck) -> dict[str, Any]:
    """``min_clearance`` [m] and ``closest`` (pair names, time [s]) of a continuous check."""
    return {
        "min_clearance": float(result.min_clearance),
        "closest": None
        if result.closest is None
        else {"links": list(result.closest[0]), "time_from_start": float(result.closest[1])},
    }


def unchecked_warnings(robot: Robot, env: Environment | None, urdf: str | None) -> tuple[str, ...]:
    """Warnings for what the collision check cannot see: each link whose collision geometry is
    mesh-only, and the obstacles of ``env`` when the robot has no collision geometry at all."""
    geometry, _ = robot_setup(robot, urdf)
    out = [
        f"link {n} has only mesh collision geometry: it is not checked"
        for n in geometry.unchecked_links
    ]
    if len(geometry.links) == 0 and env is not None and env.obstacles:
        out.append(
            "the robot has no collision geometry (no <collision> box, sphere or cylinder): the "
            "environment's obstacles are not checked"
        )
    return tuple(out)


def guard(
    robot: Robot,
    env: Environment | None,
    trajectory: Trajectory,
    *,
    urdf: str | None = None,
    allow_partial: bool = False,
    s_at: Callable[[float], float] | None = None,
    field: tuple[str | int, ...] = ("environment",),
) -> Guarded:
    """Check ``trajectory`` continuously; raise ``Collision`` or cut it (``allow_partial``).

    Args:
        robot: The request's robot.
        env: The request's ``environment`` (None: self-collision only).
        trajectory: The planned trajectory.
        urdf: The inline robot's URDF (its ``<collision>`` primitives), None for a shipped robot.
        allow_partial: Return the clear prefix instead of raising.
        s_at: Path parameter at a time [s] (Cartesian plans), for the error's ``s``.
        field: Where the environment sits in the request (for validation errors).
    """
    check = checker(robot, env, urdf, field)
    warnings = unchecked_warnings(robot, env, urdf)
    if check is None:
        return Guarded(trajectory, {}, warnings=warnings)
    times, qs = trajectory.times, trajectory.positions
    ends = check.distances(qs[[0, -1]]) - check.threshold
    for row, which in ((0, "start"), (1, "goal")):
        if (ends[row] < 0).any():
            p = int(np.argmin(ends[row]))
            a, b = check.pair_names[p]
            d = float(ends[row, p] + check.threshold[p])
            t = float(times[0] if row == 0 else times[-1])
            raise Collision(
                f"the {which} configuration is in collision: {a} and {b} are {d:.4f} m apart "
                f"(clearance {float(check.threshold[p]):g} m)",
                s=None if s_at is None else s_at(t),
                extra={"time_from_start": t, "links": [a, b], "distance": d, "at": which},
            )
    result = check.check_path(times, qs)
    diag: dict[str, Any] = _clearance(result)
    if check.geometry.unchecked_links:
        diag["collision_warnings"] = list(warnings)
    c = result.contact
    if c is None:
        diag["clearance_profile"] = clearance_profile(check, trajectory)
        return Guarded(trajectory, diag, warnings=warnings)
    s = None if s_at is None else s_at(c.time)
    err = Collision(
        f"{approach_text(c.links[0], c.links[1], c.distance)} at t = {c.time:.4f} s",
        s=s,
        extra={"time_from_start": c.time, "links": list(c.links), "distance": c.distance},
    )
    if not allow_partial:
        raise err
    k = c.index + 1  # rows 0..index: the motion up to the start of the contact segment is clear
    prefix = Trajectory(
        times[:k],
        qs[:k],
        trajectory.velocities[:k],
        trajectory.accelerations[:k],
        trajectory.joint_names,
    )
    fraction = float(times[k - 1] / times[-1]) if times[-1] > 0 else 0.0
    diag.update(_clearance(check.check_path(prefix.times, prefix.positions)))  # the prefix's own
    diag["clearance_profile"] = clearance_profile(check, prefix)
    return Guarded(prefix, diag, err, fraction, warnings)


def guard_cartesian(
    task: Any,
    result: Any,
    env: Environment | None,
    urdf: str | None,
    field: tuple[str | int, ...] = ("environment",),
    replan: Callable[[Any], Any] | None = None,
) -> Any:
    """``guard`` for a ``CartesianResult``: ``s`` from the tool's projection on the line; with
    ``allow_partial`` a contact gives the line up to just before it, planned anew by ``replan``
    (a ``CartesianTask`` -> a checked ``CartesianResult``) so the arm comes to rest there (without
    ``replan``, or when no shorter line is clear, the trajectory cut before the contact, moving)."""
    robot = task.robot
    p0 = robot.fk(task.q_start)[:3, 3]
    axis = task.T_goal[:3, 3] - p0
    length2 = float(axis @ axis)
    traj = result.trajectory

    def s_at(t: float) -> float:
        if length2 < 1e-18:  # pure rotation: s by time
            return float(np.clip(t / max(float(traj.times[-1]), 1e-12), 0.0, 1.0))
        q = np.array([np.interp(t, traj.times, traj.positions[:, j]) for j in range(robot.dof)])
        return float(np.clip((robot.fk(q)[:3, 3] - p0) @ axis / length2, 0.0, 1.0))

    g = guard(
        robot, env, traj, urdf=urdf, allow_partial=bool(task.allow_partial), s_at=s_at, field=field
    )
    diagnostics = {**result.diagnostics, **g.diagnostics}
    result = dataclasses.replace(result, warnings=(*result.warnings, *g.warnings))
    if g.failure is None:
        return dataclasses.replace(result, diagnostics=diagnostics)
    last = float(g.trajectory.times[-1])
    end = min(float(result.fraction), s_at(last))
    if replan is not None:
        stopped = _stop_before(task, replan, end, env, urdf, field)
        if stopped is not None:
            end, planned, checked = stopped
            knots = planned.knots
            if knots is not None:
                knots = {**knots, "s": knots["s"] * end}
            return dataclasses.replace(
                planned,
                fraction=end,
                failure=g.failure,
                knots=knots,
                warnings=(partial_warning(end, g.failure), *planned.warnings, *g.warnings),
                diagnostics={**planned.diagnostics, **checked.diagnostics},
            )
    # the prefix measured anew (deviation, singular values), so every diagnostic describes it
    prefix = finish(task, dataclasses.replace(result, trajectory=g.trajectory))
    return dataclasses.replace(
        prefix,
        fraction=end,
        failure=g.failure,
        warnings=(partial_warning(end, g.failure), *prefix.warnings, MOVING_END),
        diagnostics=diagnostics,
    )


MOVING_END = (
    "the answer ends moving (its last point has non-zero velocity, cut before a contact): bring "
    "the arm to rest before executing it"
)
"""Warning of a partial answer cut short by a collision without coming to rest."""
STOP_TRIES = 4
"""Shorter lines tried (each ``STOP_SHRINK`` of the last) to stop before a contact."""
STOP_SHRINK = 0.9


def _stop_before(
    task: Any,
    replan: Callable[[Any], Any],
    end: float,
    env: Environment | None,
    urdf: str | None,
    field: tuple[str | int, ...],
) -> tuple[float, Any, Guarded] | None:
    """The line of ``task`` up to ``end`` (its share of s) planned to rest by ``replan`` and clear
    of contacts, shrinking ``end`` when needed: ``(end, result, its guard)``, or None."""
    for _ in range(STOP_TRIES):
        if end < MIN_FRACTION:
            return None
        short = dataclasses.replace(task.prefix(end), q_goal=None, allow_partial=False)
        try:
            planned = replan(short)
            checked = guard(task.robot, env, planned.trajectory, urdf=urdf, field=field)
        except PlanningError:
            end *= STOP_SHRINK
            continue
        return end, planned, checked
    return None


def _clipped(segment: Any, last: float) -> Any:
    """A program segment's windows cut at ``last`` [s], the end of a partial answer (its blend out
    dropped when it had not begun by then, else ended there)."""
    if segment.end_time <= last and (segment.blend_out is None or segment.blend_out[1] <= last):
        return segment
    blend = segment.blend_out
    if blend is not None:
        blend = None if blend[0] >= last else (blend[0], last)
    return dataclasses.replace(segment, end_time=min(segment.end_time, last), blend_out=blend)


def inline_urdf(robot_ref: Any) -> str | None:
    """The URDF text of an inline robot reference, None for a registered name."""
    return getattr(robot_ref, "urdf", None) if not isinstance(robot_ref, str) else None


def guard_request(body: Any, trajectory: Trajectory) -> Guarded:
    """``guard`` for a joint-space request (``robot``, ``environment``, optional ``allow_partial``):
    nothing to check without a robot; an environment without a robot is 422 at the field."""
    env = getattr(body, "environment", None)
    if body.robot is None:
        if env is not None:
            raise InputError("an environment needs a robot", field=("environment",))
        return Guarded(trajectory, {})
    robot = registry.resolve(body.robot)
    return guard(
        robot,
        env,
        trajectory,
        urdf=inline_urdf(body.robot),
        allow_partial=bool(getattr(body, "allow_partial", False)),
    )


def guard_program(result: Any, robot: Robot, body: Any) -> Any:
    """``guard`` for a motion program (``ProgramResult``): a contact names its ``segment`` and ``s``
    within it (LIN: the tool's projection on the segment's line between its start and end; PTP and
    CIRC: the share of the segment's time); with ``allow_partial`` the program up to the contact."""
    traj = result.trajectory
    segments = [s for s in result.segments if s.end_time > s.start_time]

    def segment_at(t: float) -> Any:
        before = [s for s in segments if s.start_time <= t + 1e-12]
        return before[-1] if before else (segments[0] if segments else None)

    def q_at(t: float) -> np.ndarray:
        return np.array([np.interp(t, traj.times, traj.positions[:, j]) for j in range(robot.dof)])

    def s_at(t: float) -> float | None:
        seg = segment_at(t)
        if seg is None:
            return None
        span = seg.end_time - seg.start_time
        share = float(np.clip((t - seg.start_time) / span, 0.0, 1.0))
        if seg.type != "lin":
            return share
        p0, p1 = robot.fk(q_at(seg.start_time))[:3, 3], robot.fk(q_at(seg.end_time))[:3, 3]
        axis = p1 - p0
        if float(axis @ axis) < 1e-18:
            return share
        return float(np.clip((robot.fk(q_at(t))[:3, 3] - p0) @ axis / (axis @ axis), 0.0, 1.0))

    try:
        g = guard(
            robot,
            body.environment,
            traj,
            urdf=inline_urdf(body.robot),
            allow_partial=bool(body.allow_partial),
            s_at=s_at,
        )
    except Collision as err:
        seg = segment_at(float(err.extra["time_from_start"]))
        err.extra["segment"] = None if seg is None else seg.index
        raise
    diagnostics = {**result.diagnostics, **g.diagnostics}
    result = dataclasses.replace(result, warnings=(*result.warnings, *g.warnings))
    if g.failure is None:
        return dataclasses.replace(result, diagnostics=diagnostics)
    seg = segment_at(float(g.failure.extra["time_from_start"]))
    g.failure.extra["segment"] = None if seg is None else seg.index
    n = max(len(result.segments), 1)
    last = float(g.trajectory.times[-1])
    kept = tuple(_clipped(s, last) for s in result.segments if s.start_time < last or s.index == 0)
    # like the program's own partial plans: the segments done plus the share of the last one
    seg_last, s_last = segment_at(last), s_at(last)
    done = 0.0 if seg_last is None else (seg_last.index + (s_last or 0.0)) / n
    fraction = min(float(result.fraction), done)
    warnings = (
        f"planned {fraction:.1%} of the program: {g.failure.detail}",
        *result.warnings,
        MOVING_END,
    )
    return dataclasses.replace(
        result,
        trajectory=g.trajectory,
        segments=kept,
        warnings=warnings,
        fraction=fraction,
        failure=g.failure,
        diagnostics=diagnostics,
    )
