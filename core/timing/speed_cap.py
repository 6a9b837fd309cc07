"""A cap on the path speed s' along a joint path, as one more coordinate of the path.

The time-optimal law keeps joint velocity limits |q_s| s' <= v. A path with one more coordinate
whose rate is dq/ds = 1 / cap(s), under velocity limit 1, therefore keeps s' <= cap(s) as well:
``CappedPath`` adds that coordinate (``cap`` piecewise linear over ``knots``, which are its
``joins``: the cap's slope, so that coordinate's d2q/ds2, steps there), and ``capped_limits``
the matching limits (velocity 1, no acceleration limit; tool and effort limits see the original
coordinates only).
"""

from __future__ import annotations

import numpy as np

from core.kinematics import Dynamics
from core.timing.joint_path import JoinedPath, JointPath
from core.timing.path_constraints import Effort, PathLimits, ToolSpeed


class CappedPath:
    """``path`` with one more coordinate of rate 1 / cap(s) (a ``JointPath``; q of that
    coordinate is reported as 0: no limit reads it)."""

    def __init__(self, path: JointPath, knots: np.ndarray, cap: np.ndarray) -> None:
        self.path, self.knots, self.cap = path, np.asarray(knots, float), np.asarray(cap, float)
        self.length, self.dof = float(path.length), path.dof + 1

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        base = np.asarray(self.path(s, order))
        if order == 0:
            return np.column_stack([base, np.zeros(len(s))])
        c = np.interp(s, self.knots, self.cap)
        if order == 1:
            return np.column_stack([base, 1.0 / c])
        i = np.clip(np.searchsorted(self.knots, s, side="right") - 1, 0, len(self.knots) - 2)
        slope = np.diff(self.cap)[i] / np.diff(self.knots)[i]
        extra = -slope / c**2 if order == 2 else 2.0 * slope**2 / c**3
        return np.column_stack([base, extra])

    def breakpoints(self) -> np.ndarray:
        return np.asarray(self.path.breakpoints(), dtype=float)

    def joins(self) -> np.ndarray:
        own = self.path.joins() if isinstance(self.path, JoinedPath) else np.zeros(0)
        return np.union1d(np.asarray(own, dtype=float), self.knots)


class _FirstCoordinates:
    """``dynamics`` on all coordinates but the last (the cap's), which carries no effort."""

    def __init__(self, dynamics: Dynamics) -> None:
        self.dynamics = dynamics

    def inverse_dynamics(self, q, qd, qdd, gravity):  # type: ignore[no-untyped-def]
        tau = self.dynamics.inverse_dynamics(q[:, :-1], qd[:, :-1], qdd[:, :-1], gravity)
        return np.column_stack([tau, np.zeros(len(tau))])

    def path_coefficients(self, q, dq, ddq, gravity):  # type: ignore[no-untyped-def]
        parts = self.dynamics.path_coefficients(q[:, :-1], dq[:, :-1], ddq[:, :-1], gravity)
        return tuple(np.column_stack([p, np.zeros(len(p))]) for p in parts)


def capped_limits(limits: PathLimits) -> PathLimits:
    """``limits`` for a ``CappedPath``: the cap's coordinate under velocity limit 1 only."""
    tool = limits.tool
    if tool is not None:
        rates = tool.rates
        tool = ToolSpeed(lambda q, dq: rates(q[:, :-1], dq[:, :-1]), tool.max_linear,
                         tool.max_angular)  # fmt: skip
    effort = limits.effort
    if effort is not None:
        effort = Effort(_FirstCoordinates(effort.dynamics),  # type: ignore[arg-type]
                        np.append(effort.limits, np.inf), effort.gravity)  # fmt: skip
    return PathLimits(np.append(limits.velocity, 1.0), np.append(limits.acceleration, np.inf),
                      tool=tool, effort=effort)  # fmt: skip
