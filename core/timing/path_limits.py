"""Limits along a joint path, and what they make of the path speed: caps on s' and bounds on s''.

A path timing law (``TIMING_LAWS`` with ``TimingSpec.path`` set) times a geometric joint path
q(s) (``core.timing.joint_path.JointPath``) under ``PathLimits``: joint velocity and acceleration
limits and tool speed and acceleration limits, given at a grid of s that holds the path's
breakpoints. With q' = q_s s' and q'' = q_s s'' + q_ss s'^2 (q_s = dq/ds):

- |q_s| s' <= v_max caps s' (``cap``), so does each tool speed limit over the tool's rate per unit
  s (|J_v q_s|, |J_w q_s|);
- ``ACCELERATION_SHARE`` of each joint's acceleration limit goes to the curvature term
  |q_ss| s'^2 (another cap on s'), the rest bounds |q_s| |s''| (with the tool accelerations, the
  bound on |s''| of each grid interval).

The split makes both hold at the grid points whatever the sign of s''; it is conservative (a
time-optimal law shares each limit exactly, ``core.timing.topp``). Units: [rad or m], [s].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.timing.joint_path import JointPath
from core.timing.path_constraints import PathLimits as Rows

ACCELERATION_SHARE = 0.5
"""Share of each joint's acceleration limit given to the curvature term |q_ss| s'^2."""
CAP_MARGIN = 0.98
"""Caps are applied this much tightened: the law through the timed grid may overshoot a bit."""
TINY = 1e-12


@dataclass(frozen=True)
class PathLimits:
    """Limits along a joint path, at its grid.

    Attributes:
        s: ``(K,)`` increasing grid of the path parameter from 0 to ``path.length``, holding
            ``path.breakpoints()``.
        velocity: ``(K, dof)`` joint speed limits [rad/s] at each grid point.
        acceleration: ``(K, dof)`` joint acceleration limits [rad/s^2].
        tool_rate: ``(K, 2)`` the tool's linear [m] and angular [rad] rate per unit s.
        tool_speed: ``(K, 2)`` tool speed limits [m/s, rad/s] (inf: none).
        tool_acceleration: ``(K, 2)`` tool acceleration limits [m/s^2, rad/s^2] (inf: none).
        tool_positions: ``(K, 3)`` the tool's position [m] at each grid point (the jerk-limited
            law bounds the tool's linear jerk along it), or None.
        tool_jerk: Tool jerk limits [m/s^3, rad/s^3] of a jerk-limited law, or None.
        rows: The same limits at any s, as rows affine in (s'', s'^2)
            (``core.timing.path_constraints.PathLimits``: what the time-optimal law keeps, effort
            included), or None.
    """

    s: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    tool_rate: np.ndarray
    tool_speed: np.ndarray
    tool_acceleration: np.ndarray
    tool_positions: np.ndarray | None = None
    tool_jerk: tuple[float, float] | None = None
    rows: Rows | None = None


@dataclass(frozen=True)
class PathCaps:
    """What the limits make of the path speed on the grid.

    Attributes:
        cap: ``(K,)`` largest s' [1/s] at each grid point (``CAP_MARGIN`` applied).
        acceleration: ``(K-1,)`` bound on |s''| [1/s^2] on each grid interval.
    """

    cap: np.ndarray
    acceleration: np.ndarray


def _ratio(limit: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """``limit / rate`` where ``rate`` > ``TINY``, inf elsewhere (elementwise)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(rate > TINY, limit / np.where(rate > TINY, rate, 1.0), np.inf)


def path_caps(path: JointPath, limits: PathLimits) -> PathCaps:
    """The caps on s' and bounds on |s''| of ``limits`` along ``path`` (the module docstring)."""
    s = limits.s
    dq, d2q = np.abs(path(s, 1)), np.abs(path(s, 2))
    caps = [
        np.min(_ratio(limits.velocity, dq), axis=1),
        np.sqrt(np.min(_ratio(ACCELERATION_SHARE * limits.acceleration, d2q), axis=1)),
        _ratio(limits.tool_speed[:, 0], limits.tool_rate[:, 0]),
        _ratio(limits.tool_speed[:, 1], limits.tool_rate[:, 1]),
    ]
    acc = [
        np.min(_ratio((1.0 - ACCELERATION_SHARE) * limits.acceleration, dq), axis=1),
        _ratio(limits.tool_acceleration[:, 0], limits.tool_rate[:, 0]),
        _ratio(limits.tool_acceleration[:, 1], limits.tool_rate[:, 1]),
    ]
    acc_s = CAP_MARGIN * np.minimum.reduce(acc)
    interval = np.minimum(acc_s[:-1], acc_s[1:])
    return PathCaps(
        cap=CAP_MARGIN * np.minimum.reduce(caps),
        acceleration=np.where(np.isfinite(interval), interval, 1e6),
    )
