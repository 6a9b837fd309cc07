"""The Cartesian planners' joint-limit tests, in one place with one slack.

Every position and speed test of a Cartesian method (a walk's IK solution, a knot path, a returned
trajectory, a control step, the start and goal of a task) goes through these functions, so they
agree to the last digit on what "inside the limits" means. ``core.limits`` (the joint team's)
checks request values and joint-space plans; its messages and error data are shaped for those
routes, so the Cartesian tests live here (the integrator may fold the two together).
Units: positions [rad or m], limits ``(dof, 2)``; speeds [rad/s or m/s], limits ``(dof,)``.
"""

from __future__ import annotations

import numpy as np

LIMIT_SLACK = 1e-9
"""Rounding slack: a position may pass a limit by this share of the joint's range (at least 1 rad or
m), a speed by this share of its limit."""


def outside(q: np.ndarray, position_limits: np.ndarray) -> np.ndarray:
    """Which joint positions of ``q`` ``(..., dof)`` are outside ``position_limits`` ``(dof, 2)``
    by more than the slack: a bool array of ``q``'s shape."""
    lo, hi = position_limits[:, 0], position_limits[:, 1]
    slack = LIMIT_SLACK * np.maximum(hi - lo, 1.0)
    return (q < lo - slack) | (q > hi + slack)


def inside(q: np.ndarray, position_limits: np.ndarray) -> np.ndarray:
    """Whether each configuration of ``q`` ``(..., dof)`` is inside the limits: shape ``(...)``."""
    return ~outside(q, position_limits).any(axis=-1)


def worst_joint(q: np.ndarray, position_limits: np.ndarray) -> int:
    """The joint of ``q`` ``(dof,)`` farthest outside (or least inside) its position limits."""
    lo, hi = position_limits[:, 0], position_limits[:, 1]
    return int(np.argmax(np.maximum(lo - q, q - hi)))


def over_speed(velocities: np.ndarray, velocity_limits: np.ndarray) -> np.ndarray:
    """Which joint speeds of ``velocities`` ``(..., dof)`` exceed ``velocity_limits`` ``(dof,)`` by
    more than the slack: a bool array of ``velocities``' shape."""
    return np.abs(velocities) > velocity_limits * (1.0 + LIMIT_SLACK)
