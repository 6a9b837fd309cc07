"""The collision stage of every planner: ``check_ends`` before planning, ``check_motion`` after.

Any planner that produces a ``Trajectory`` (Cartesian methods, programs, joint profiles and
splines, and round 3's collision-free motions and retimed paths) hands it to ``check_motion``
with the request's ``Clearance`` (``core.kinematics``): a continuous check, the joints moving
linearly between consecutive returned points, that finds the first contact (a pair closer than its
threshold: the clearance for obstacles, 0 for self pairs) and the smallest distance over the whole
motion. The planner turns a contact into the ``Collision`` a 422 carries (``collision_error``, with
its own ``s`` and segment) or, with ``allow_partial``, stops before it: ``cut_before`` keeps the
returned points up to the segment that holds the contact (the motion up to there is clear); the
Cartesian and program planners bring the arm to rest instead (``core.cartesian.stop``,
``core.program.stop``).

``check_ends`` checks configurations known before planning (the start, a goal given as joints)
so a request that starts in collision is refused at once (``at``: ``"start"`` or ``"goal"``). A
pair whose robot link sits at the base (fixed to it, or moved by the first joint alone: its row of
``motion_weights`` is zero past the first joint, so no arm motion takes it away from, say, a table
under the base) names ``environment.allowed_collisions`` in its detail.
Units: [m], [s], joint positions [rad or m].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.clearance import approach_text
from core.errors import Collision
from core.kinematics import Clearance
from core.trajectory import Trajectory

PROFILE_POINTS = 200
"""Most returned points of a ``ClearanceReport`` profile (evenly spread, both ends included)."""
STOP_TRIES = 4
"""Stops tried before a contact by the planners that bring the arm to rest instead of refusing
(``core.cartesian.stop``: shorter paths, ``core.program.stop``: earlier stops), each
``STOP_SHRINK`` of the last."""
STOP_SHRINK = 0.9

MOVING_END = (
    "the answer ends moving (its last point has non-zero velocity, cut before a contact): bring "
    "the arm to rest before executing it"
)
"""Warning of a partial answer cut before a contact without coming to rest."""
ALLOWED_HINT = (
    "; {link} sits at the base (fixed to it, or turned by the first joint alone), so no motion of "
    "the arm leaves this contact: if {other} is meant to touch it (a table under the base), list "
    'the pair in environment.allowed_collisions, e.g. [["{link}", "{other}"]]'
)


@dataclass(frozen=True)
class ClearanceReport:
    """How close a checked motion came to contact.

    Attributes:
        min_clearance: [m] the smallest pair distance over the whole motion (inf: no pair).
        closest: ``(links, time [s])`` of that distance, or None.
        profile_times: ``(K,)`` [s] times of up to ``PROFILE_POINTS`` returned points.
        profile_values: ``(K,)`` [m] the smallest pair distance at each of them.
    """

    min_clearance: float
    closest: tuple[tuple[str, str], float] | None
    profile_times: np.ndarray
    profile_values: np.ndarray


@dataclass(frozen=True)
class ContactFound:
    """The first contact of a checked motion.

    Attributes:
        time: [s] from the start of the motion.
        q: ``(dof,)`` the configuration there (joints linear between the returned points).
        links: ``(robot_link, obstacle_name_or_link)``.
        distance: [m] signed (negative: penetration).
        index: The returned points ``0..index`` and the motion between them are clear.
    """

    time: float
    q: np.ndarray
    links: tuple[str, str]
    distance: float
    index: int


@dataclass(frozen=True)
class MotionCheck:
    """What ``check_motion`` found: the report and the first contact (None: clear)."""

    report: ClearanceReport
    contact: ContactFound | None


@dataclass(frozen=True)
class End:
    """A configuration a motion starts or ends at.

    Attributes:
        at: ``"start"`` or ``"goal"``.
        q: ``(dof,)`` joint positions, or None when not known yet (a goal pose before IK).
        time: [s] when the motion is there (None: not known yet).
        s: The path parameter there (paths), or None.
        segment: A program's segment, or None.
    """

    at: str
    q: np.ndarray | None
    time: float | None = None
    s: float | None = None
    segment: int | None = None


def check_ends(clearance: Clearance | None, ends: tuple[End, ...]) -> None:
    """Raise ``Collision`` (``at``, ``links``, ``distance``) for the first of ``ends`` already in
    collision (ends whose ``q`` is None are skipped)."""
    if clearance is None:
        return
    known = [e for e in ends if e.q is not None]
    if not known:
        return
    qs = np.array([np.asarray(e.q, dtype=float) for e in known])
    margin = clearance.distances(qs) - clearance.threshold
    for end, row in zip(known, margin, strict=True):
        if (row < 0).any():
            raise end_collision(clearance, end, int(np.argmin(row)), float(np.min(row)))


def end_collision(clearance: Clearance, end: End, pair: int, margin: float) -> Collision:
    """The ``Collision`` of an end configuration whose pair ``pair`` is ``margin`` [m] inside its
    threshold."""
    which = end.at
    a, b = clearance.pair_names[pair]
    threshold = float(clearance.threshold[pair])
    d = margin + threshold
    hint = ""
    if not np.any(clearance.motion_weights[pair][1:]):
        hint = ALLOWED_HINT.format(link=a, other=b)
    extra: dict[str, object] = {"links": [a, b], "distance": d, "at": which}
    if end.time is not None:
        extra["time_from_start"] = end.time
    if end.segment is not None:
        extra["segment"] = end.segment
    return Collision(
        f"the {which} configuration is in collision: {approach_text(a, b, d)} "
        f"(clearance {threshold:g} m){hint}",
        s=end.s,
        extra=extra,
    )


def check_motion(trajectory: Trajectory, clearance: Clearance) -> MotionCheck:
    """The continuous check of ``trajectory`` (joints linear between its returned points): the
    clearance report and the first contact (see the module docstring)."""
    times, qs = trajectory.times, trajectory.positions
    found = clearance.check_path(times, qs)
    contact = None
    c = found.contact
    if c is not None:
        k = min(int(c.index), len(times) - 2) if len(times) > 1 else 0
        share = 0.0
        if len(times) > 1 and times[k + 1] > times[k]:
            share = float(np.clip((c.time - times[k]) / (times[k + 1] - times[k]), 0.0, 1.0))
        q = qs[k] if len(times) < 2 else qs[k] + share * (qs[k + 1] - qs[k])
        contact = ContactFound(float(c.time), q, tuple(c.links), float(c.distance), int(c.index))  # type: ignore[arg-type]
    return MotionCheck(report(trajectory, clearance, found.min_clearance, found.closest), contact)


def report(
    trajectory: Trajectory,
    clearance: Clearance,
    min_clearance: float,
    closest: tuple[tuple[str, str], float] | None,
) -> ClearanceReport:
    """The ``ClearanceReport`` of a checked motion (its profile at up to ``PROFILE_POINTS``: the
    smallest pair distance at each, ``clearance.min_distances`` when it has one)."""
    n = len(trajectory.times)
    rows = np.unique(np.round(np.linspace(0, n - 1, min(n, PROFILE_POINTS))).astype(int))
    smallest = getattr(clearance, "min_distances", None)  # a clearance may know a faster way
    if smallest is not None:
        values = np.asarray(smallest(trajectory.positions[rows]), dtype=float)
    else:
        d = clearance.distances(trajectory.positions[rows])
        values = d.min(axis=1) if d.shape[1] else np.full(len(rows), np.inf)
    return ClearanceReport(float(min_clearance), closest, trajectory.times[rows].copy(), values)


def collision_error(
    contact: ContactFound, *, s: float | None = None, segment: int | None = None
) -> Collision:
    """The ``Collision`` a 422 carries for ``contact`` (``s``: where on the path, when the motion
    follows one; ``segment``: a program's segment)."""
    extra: dict[str, object] = {
        "time_from_start": contact.time,
        "links": list(contact.links),
        "distance": contact.distance,
    }
    if segment is not None:
        extra["segment"] = segment
    return Collision(
        f"{approach_text(contact.links[0], contact.links[1], contact.distance)} at "
        f"t = {contact.time:.4f} s",
        s=s,
        extra=extra,
    )


def cut_before(trajectory: Trajectory, contact: ContactFound) -> Trajectory:
    """The returned points up to the start of the segment that holds ``contact`` (the motion up to
    there is clear); it ends moving (``MOVING_END``)."""
    k = contact.index + 1
    return Trajectory(
        trajectory.times[:k],
        trajectory.positions[:k],
        trajectory.velocities[:k],
        trajectory.accelerations[:k],
        trajectory.joint_names,
    )


def checked(trajectory: Trajectory, clearance: Clearance | None) -> ClearanceReport | None:
    """The check of a motion that follows no path and has no partial answer (joint moves,
    splines): its report, or ``Collision`` at the first contact; None when nothing is checked."""
    if clearance is None:
        return None
    found = check_motion(trajectory, clearance)
    if found.contact is not None:
        raise collision_error(found.contact)
    return found.report
