"""Effort limits and gravity of a request that chooses its own timing -> ``core`` inputs.

``effort_inputs`` gives the ``core.timing.path_constraints.Effort`` of a request's
``limits.effort`` (None when it gives none: effort limits apply only when asked for), checking that
the robot has dynamics (422 ``validation`` at ``limits.effort`` otherwise) and the length;
``gravity_of`` the request's gravity in the base frame (default ``DEFAULT_GRAVITY``);
``dynamics_of`` the robot's dynamics when it has them (for ``peak_effort``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from core.errors import InputError
from core.kinematics import DEFAULT_GRAVITY, Dynamics
from core.limits import joint_vector
from core.timing.path_constraints import Effort
from robots.model import Robot

EFFORT_FIELD = ("limits", "effort")


def gravity_of(body: Any, robot: Robot | None) -> np.ndarray:
    """The request's ``gravity`` [m/s^2] ``(3,)`` (default [0, 0, -9.81]); 422 at ``gravity``
    when it is given for a request without a robot with dynamics."""
    given = getattr(body, "gravity", None)
    if given is not None and dynamics_of(robot) is None:
        raise InputError("gravity applies to a robot with dynamics", field=("gravity",))
    return np.asarray(DEFAULT_GRAVITY if given is None else given, dtype=float)


def dynamics_of(robot: Robot | None) -> Dynamics | None:
    """The robot's dynamics, or None (no robot, or no inertial parameters)."""
    return None if robot is None else getattr(robot, "dynamics", None)


def effort_inputs(body: Any, robot: Robot | None, dof: int) -> Effort | None:
    """``Effort`` of ``body.limits.effort`` under the robot's dynamics and the request's
    gravity, or None when the request gives no effort limits."""
    limits = getattr(body, "limits", None)
    effort = getattr(limits, "effort", None)
    gravity = gravity_of(body, robot)
    if effort is None:
        return None
    dynamics = dynamics_of(robot)
    if robot is None or dynamics is None:
        raise InputError(
            "limits.effort needs a robot with dynamics (inertial parameters); "
            + ("this request names none" if robot is None else f"{robot.name} has none"),
            field=EFFORT_FIELD,
        )
    return Effort(dynamics, joint_vector(effort, dof, EFFORT_FIELD), gravity)
