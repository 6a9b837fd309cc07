"""Per-joint limits and the one set of checks of request values and plans against them.

``JointLimits`` holds velocity, acceleration, jerk and position limits (``None``: not known,
unbounded); ``joint_vector`` validates one value per joint. The checks, with one slack
(``LIMIT_SLACK``: a position may pass a limit by this share of the joint's finite range, at least
1 rad or m; a rate by this share of its limit) for every planner, joint, Cartesian and program:

- masks, for planners that decide what to do with a violation: ``outside`` (``inside``,
  ``worst_joint``) and ``over_rate_limit`` (``over_speed``);
- raising checks: ``check_rates``, ``check_boundary_rates``, ``check_positions`` and
  ``entry_positions`` (a request's joint positions: one per joint, finite, inside the limits) raise
  ``JointRateLimit`` / ``JointLimit`` with the joint, and the request field or the sample at fault.

Units: [rad or m], per [s], per [s^2], per [s^3]; arrays ``(dof,)`` or ``(N, dof)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from core.errors import InputError, JointLimit, JointRateLimit

LIMIT_SLACK = 1e-9
"""Rounding slack: a position may pass a limit by this share of the joint's range (at least 1 rad
or m), a speed, acceleration or jerk by this share of its limit."""

Field = tuple[str | int, ...]


def joint_vector(
    value: object, dof: int, field: Field, *, default: float | None = None
) -> np.ndarray:
    """``value`` as a finite float array ``(dof,)``; ``None`` gives ``default`` everywhere.

    Raises:
        InputError: naming ``field`` when the length is not ``dof`` or a value is not finite.
    """
    if value is None:
        if default is None:
            raise InputError(f"{_dotted(field)} is required", field=field)
        return np.zeros(dof) if default == 0.0 else np.full(dof, float(default))
    arr = np.asarray(value, dtype=float)
    if arr.shape != (dof,):
        raise InputError(f"{_dotted(field)} needs {dof} values, one per joint", field=field)
    # A finite dot product means every value is finite (NaN and inf propagate); an overflowing
    # one is settled by the exact check.
    if not math.isfinite(arr @ arr) and not np.isfinite(arr).all():
        raise InputError(f"{_dotted(field)} must hold finite numbers", field=field)
    return arr


def _dotted(field: Field) -> str:
    return ".".join(str(p) for p in field)


def outside(q: np.ndarray, position_limits: np.ndarray) -> np.ndarray:
    """Which joint positions of ``q`` ``(..., dof)`` are outside ``position_limits`` ``(dof, 2)``
    (lower, upper; infinite allowed) by more than the slack: a bool array of ``q``'s shape."""
    lo, hi = position_limits[:, 0], position_limits[:, 1]
    span = hi - lo
    slack = LIMIT_SLACK * np.maximum(np.where(np.isfinite(span), span, 1.0), 1.0)
    return np.asarray((q < lo - slack) | (q > hi + slack))


def inside(q: np.ndarray, position_limits: np.ndarray) -> np.ndarray:
    """Whether each configuration of ``q`` ``(..., dof)`` is inside the limits: shape ``(...)``."""
    return np.asarray(~outside(q, position_limits).any(axis=-1))


def worst_joint(q: np.ndarray, position_limits: np.ndarray) -> int:
    """The joint of ``q`` ``(dof,)`` farthest outside (or least inside) its position limits."""
    lo, hi = position_limits[:, 0], position_limits[:, 1]
    return int(np.argmax(np.maximum(lo - q, q - hi)))


def over_rate_limit(
    values: np.ndarray, limit: np.ndarray, tolerance: float = LIMIT_SLACK
) -> np.ndarray:
    """Boolean mask, ``values``' shape: True where ``|values|`` exceeds ``limit`` ``(dof,)`` (a
    velocity, acceleration or jerk limit, ``inf`` allowed) by more than the relative ``tolerance``."""
    return np.abs(values) > limit * (1.0 + tolerance)


def over_speed(velocities: np.ndarray, velocity_limits: np.ndarray) -> np.ndarray:
    """Which joint speeds of ``velocities`` ``(..., dof)`` exceed ``velocity_limits`` ``(dof,)`` by
    more than the slack: a bool array of ``velocities``' shape."""
    return over_rate_limit(velocities, velocity_limits)


class LimitedChain(Protocol):
    """The limit members of ``core.kinematics.Kinematics`` (any robot model has them)."""

    @property
    def position_limits(self) -> np.ndarray: ...

    @property
    def velocity_limits(self) -> np.ndarray: ...

    @property
    def acceleration_limits(self) -> np.ndarray: ...


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits; ``None`` means the limit is not known (treated as unbounded).

    Attributes:
        velocity: Speed limits ``(dof,)`` in [rad/s or m/s], > 0 (``inf`` allowed).
        acceleration: Acceleration limits ``(dof,)`` in [rad/s^2 or m/s^2], > 0 (``inf`` allowed).
        position: Position limits ``(dof, 2)`` lower, upper in [rad or m] (``±inf`` allowed).
        jerk: Jerk limits ``(dof,)`` in [rad/s^3 or m/s^3], > 0 (``inf`` allowed).
    """

    velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None
    position: np.ndarray | None = None
    jerk: np.ndarray | None = None

    @classmethod
    def of(cls, robot: LimitedChain, jerk: np.ndarray | None = None) -> JointLimits:
        """The position, velocity and acceleration limits of ``robot`` (and ``jerk`` if known)."""
        return cls(
            velocity=np.asarray(robot.velocity_limits, dtype=float),
            acceleration=np.asarray(robot.acceleration_limits, dtype=float),
            position=np.asarray(robot.position_limits, dtype=float),
            jerk=jerk,
        )

    def validate(self, dof: int) -> None:
        """Check shapes and values against ``dof``; raise ``InputError`` naming ``limits.*``."""
        for name in ("velocity", "acceleration", "jerk"):
            lim = getattr(self, name)
            if lim is None:
                continue
            field = ("limits", name)
            if np.shape(lim) != (dof,):
                raise InputError(f"limits.{name} needs {dof} values, one per joint", field=field)
            if np.any(np.isnan(lim)) or np.any(lim <= 0):
                raise InputError(f"limits.{name} must be > 0 for every joint", field=field)
        if self.position is not None:
            pos = self.position
            if np.shape(pos) != (dof, 2) or np.any(np.isnan(pos)) or np.any(pos[:, 0] > pos[:, 1]):
                raise InputError("position limits must be (dof, 2) with lower <= upper", field=None)

    def maxima(self, dof: int) -> tuple[np.ndarray, np.ndarray]:
        """``(max_velocity, max_acceleration)``, each ``(dof,)``, ``inf`` where unknown."""
        return tuple(  # type: ignore[return-value]
            np.full(dof, np.inf) if lim is None else np.asarray(lim, dtype=float)
            for lim in (self.velocity, self.acceleration)
        )


def check_rates(
    peak_velocity: np.ndarray | None,
    peak_acceleration: np.ndarray | None,
    limits: JointLimits,
    joint_names: Sequence[str],
    *,
    peak_jerk: np.ndarray | None = None,
    tolerance: float = LIMIT_SLACK,
    hint: Callable[[], str] | None = None,
) -> None:
    """Raise ``JointRateLimit`` for the joint that exceeds a velocity, acceleration or jerk limit
    most (velocity first).

    Args:
        peak_velocity: Largest |velocity| per joint ``(dof,)`` or ``None`` to skip.
        peak_acceleration: Largest |acceleration| per joint ``(dof,)`` or ``None`` to skip.
        peak_jerk: Largest |jerk| per joint ``(dof,)`` or ``None`` to skip.
        tolerance: Relative slack.
        hint: Called only on failure; its text ends the message (say, the shortest duration).
    """
    for kind, peak, limit in (
        ("velocity", peak_velocity, limits.velocity),
        ("acceleration", peak_acceleration, limits.acceleration),
        ("jerk", peak_jerk, limits.jerk),
    ):
        if peak is None or limit is None:  # an unknown limit is infinite: nothing to check
            continue
        with np.errstate(over="ignore"):  # a tiny limit gives an infinite ratio: still over
            ratio = np.asarray(peak, dtype=float) / limit  # 0 where the limit is inf
        j = int(np.argmax(ratio))
        if ratio[j] > 1.0 + tolerance:
            raise JointRateLimit(
                f"joint {joint_names[j]} would exceed its {kind} limit by "
                f"{min(100.0 * (ratio[j] - 1.0), 1e300):.3g} %{hint() if hint else ''}",
                joint=j,
                extra={"limit": kind, "ratio": float(ratio[j])},
            )


def check_boundary_rates(
    value: np.ndarray, limit: np.ndarray, field: Field, joint_names: Sequence[str]
) -> None:
    """Raise ``JointRateLimit`` naming ``field + (joint,)`` where a boundary ``|value|`` ``(dof,)``
    exceeds ``limit`` ``(dof,)``: no timing can fix a start or goal state over the limits."""
    exceeds = over_rate_limit(value, limit, 0.0)
    if exceeds.any():
        over = exceeds.nonzero()[0]
        j = int(over[0])
        raise JointRateLimit(
            f"{_dotted(field)} of joint {joint_names[j]} is over its limit",
            field=(*field, j),
            joint=j,
        )


def check_positions(
    positions: np.ndarray,
    limits: JointLimits,
    joint_names: Sequence[str],
    *,
    field: Field | None = None,
    times: np.ndarray | None = None,
) -> None:
    """Raise ``JointLimit`` at the first value of ``positions`` ``(N, dof)`` outside the limits.

    With ``field`` the rows are request values (the error names ``field + (row, joint)``, or
    ``field + (joint,)`` for one row); with ``times`` they are samples of a plan.
    """
    if limits.position is None:
        return
    bad = outside(positions, limits.position)
    if not bad.any():
        return
    row, j = (int(i) for i in np.argwhere(bad)[0])
    name = joint_names[j]
    if field is not None:
        loc = (*field, j) if positions.shape[0] == 1 else (*field, row, j)
        raise JointLimit(
            f"{_dotted(loc)}: joint {name} is outside its position limits", field=loc, joint=j
        )
    when = "" if times is None else f" at t={float(times[row]):.6g} s"
    raise JointLimit(
        f"the plan takes joint {name} outside its position limits{when}", joint=j, sample=row
    )


def entry_positions(
    values: object,
    position_limits: np.ndarray,
    joint_names: Sequence[str],
    field: Field,
    *,
    s: float | None = None,
    extra: dict[str, object] | None = None,
) -> np.ndarray:
    """A request's joint positions at ``field``: ``(dof,)`` finite values (``InputError``), inside
    ``position_limits`` (``JointLimit`` naming ``field + (joint,)``, the joint, its name and
    limits, ``s`` and ``extra``) with the one slack of every planner. The one entry check of the
    routes."""
    dof = len(joint_names)
    q = joint_vector(values, dof, field)
    bad = outside(q, position_limits)
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        raise JointLimit(
            f"{_dotted(field)}[{j}] is outside the position limits of joint '{joint_names[j]}'",
            field=(*field, j),
            joint=j,
            s=s,
            extra={
                "joint_name": joint_names[j],
                "limits": [float(position_limits[j, 0]), float(position_limits[j, 1])],
                **(extra or {}),
            },
        )
    return q
