"""Timing a collision-free motion's geometric path: the one place the timing law is chosen.

``time_optimal`` (``time_path``): the blended path (``core.joint.blended_path.BlendedPath``) timed
by the time-optimal law of ``core.timing.topp`` under ``PathLimits`` (joint velocity and
acceleration; effort when the route gives it): the shortest rest-to-rest motion whose limits hold at
every instant, not only at grid points. Its answer (``TimeOptimal``) samples q(s(t)) with the exact
derivatives, has s'' constant between its ``switch_times``, and stops at the path's sharp corners
(dq/ds jumps there).

``jerk_limited`` (``StopAndGo``) keeps jerk limits: the straight segments through the knots, each a
rest-to-rest S-curve (``core.timing.s_curve.SCurveTiming``, Ruckig) along its own line, the joints'
velocity, acceleration and jerk limits divided by the segment's direction components; the path is
exactly the polyline that was certified, and the acceleration is continuous (linear between its
switch times).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.joint.blended_path import BlendedPath
from core.timing.path_constraints import PathLimits
from core.timing.s_curve import SCurveTiming
from core.timing.topp import TimeOptimal, time_optimal

TIMINGS = ("time_optimal", "jerk_limited")
"""The timings a collision-free motion takes (``time_path``; ``StopAndGo``)."""


class Motion(Protocol):
    """A timed joint motion from rest to rest: ``duration`` [s], ``switch_times`` ``(M,)`` [s]
    (0 and ``duration`` included: where the acceleration jumps or kinks), ``sample(times)`` -> q,
    q', q''."""

    duration: float
    switch_times: np.ndarray

    def sample(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


def time_path(
    path: BlendedPath,
    limits: PathLimits,
    *,
    joint_names: tuple[str, ...] = (),
    deadline: Deadline = NO_DEADLINE,
) -> TimeOptimal:
    """The time-optimal motion along ``path`` under ``limits`` (``core.timing.topp``)."""
    return time_optimal(path, limits, joint_names=joint_names, deadline=deadline)


class StopAndGo:
    """Rest-to-rest jerk-limited S-curves along the straight segments through ``knots``."""

    def __init__(
        self, knots: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, jerk: np.ndarray
    ) -> None:
        self.knots = np.asarray(knots, dtype=float)
        steps = np.diff(self.knots, axis=0)
        keep = np.linalg.norm(steps, axis=1) > 0
        self.knots = np.vstack([self.knots[:1], self.knots[1:][keep]])
        steps = steps[keep]
        self.steps = steps
        self.laws = []
        for d in steps:
            moving = np.abs(d) > 0
            bound = [float(np.min(lim[moving] / np.abs(d[moving])))
                     for lim in (velocity, acceleration, jerk)]  # fmt: skip
            self.laws.append(SCurveTiming(max_velocity=bound[0], max_acceleration=bound[1],
                                          max_jerk=bound[2]))  # fmt: skip
        self.starts = np.concatenate([[0.0], np.cumsum([law.duration for law in self.laws])])
        self.duration = float(self.starts[-1])
        inner = [a + law.switch_times() for a, law in zip(self.starts[:-1], self.laws, strict=True)]
        self.switch_times = np.unique(np.concatenate([self.starts, *inner]))

    def sample(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        times = np.asarray(times, dtype=float)
        n, dof = len(times), self.knots.shape[1]
        q, qd, qdd = np.empty((n, dof)), np.zeros((n, dof)), np.zeros((n, dof))
        if not self.laws:
            q[:] = self.knots[0]
            return q, qd, qdd
        k = np.clip(np.searchsorted(self.starts, times, side="right") - 1, 0, len(self.laws) - 1)
        for i in np.unique(k):
            m = k == i
            t = times[m] - self.starts[i]
            law, d = self.laws[i], self.steps[i]
            q[m] = self.knots[i] + law(t)[:, None] * d
            qd[m] = law(t, 1)[:, None] * d
            qdd[m] = law(t, 2)[:, None] * d
        return q, qd, qdd
