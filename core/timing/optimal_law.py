"""The ``time_optimal`` timing law: ``core.timing.topp.time_optimal`` behind the ``PathLaw`` shape.

``OptimalLaw`` is a ``TimeOptimal`` profile seen as a law of ``core.timing.TIMING_LAWS``: s(t) and
its derivatives (s''' is zero between switches: s'' is constant on every grid interval),
``time_at``, and ``switch_times()``, the grid times inside the motion where s'' steps (a program
returns a pair of points around each, so integrating the returned accelerations gives the returned
velocities). ``binding``, ``grid_duration`` and ``peak_ratio`` are the profile's own.
``time_optimal_law`` reads a ``TimingSpec``'s joint path and its limits as rows
(``core.timing.path_limits.PathLimits.rows``: joint, tool speed and acceleration, effort; limits
that change along the path as ``local`` factors).
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.errors import Infeasible, InputError
from core.timing.joint_path import JointPath
from core.timing.path_constraints import PathLimits
from core.timing.topp import Binding, TimeOptimal, time_optimal
from core.trajectory import MAX_DURATION


class OptimalLaw:
    """A ``TimeOptimal`` profile as a ``PathLaw`` (see the module docstring)."""

    keeps_effort = True
    """The effort limits of its rows hold already (``core.program.effort``)."""

    def __init__(self, profile: TimeOptimal) -> None:
        self.profile = profile
        self.duration = float(profile.duration)

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s (order 0), s' [1/s], s'' [1/s^2] at ``t`` [s]; s''' (order 3) is 0 between switches."""
        if order >= 3:
            return np.zeros(np.shape(np.asarray(t, dtype=float)))
        return np.asarray(self.profile(t, order), dtype=float)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        return np.asarray(self.profile.time_at(s), dtype=float)

    def switch_times(self) -> np.ndarray:
        """Grid times [s] strictly inside the motion where s'' steps."""
        t = np.asarray(self.profile.switch_times, dtype=float)[1:-1]
        steps = np.abs(np.diff(self.profile.profile.sddot)) > 0.0
        return t[steps]

    @property
    def binding(self) -> tuple[Binding, ...]:
        return self.profile.binding

    @property
    def grid_duration(self) -> float:
        return float(self.profile.grid_duration)


def optimal(
    path: JointPath,
    limits: PathLimits | None,
    joint_names: tuple[str, ...] = (),
    deadline: Deadline = NO_DEADLINE,
) -> OptimalLaw:
    """The time-optimal law of ``path`` under ``limits`` (``InputError`` without them;
    ``Infeasible`` when the limits leave no motion of at most ``MAX_DURATION``)."""
    if limits is None:
        raise InputError("the time-optimal law needs the limits as rows (PathLimits.rows)")
    try:
        profile = time_optimal(path, limits, joint_names=joint_names, deadline=deadline)
    except InputError as err:  # a speed of zero inside the path
        raise Infeasible("the limits leave no motion along the path (a speed of zero)") from err
    if not profile.duration <= MAX_DURATION:
        raise Infeasible(
            f"the stretch would last {profile.duration:.4g} s under these limits, over the "
            f"{MAX_DURATION:g} s bound of any trajectory"
        )
    return OptimalLaw(profile)
