"""Request -> core inputs, core result -> response body: one module per resource.

``service.convert.cartesian``: Cartesian requests (``/v1/trajectories/cartesian``, ``/v1/compare``).
``service.convert.joint``: the joint team's joint and spline conversion (formerly
``service/convert.py``), re-exported here so ``from service import convert`` and
``convert.joint_inputs`` keep working.
"""

from __future__ import annotations

from service.convert.joint import (
    JointInputs,
    SplineInputs,
    joint_inputs,
    joint_limits,
    resolve_robot,
    spline_inputs,
    trajectory_response,
)

__all__ = [
    "JointInputs",
    "SplineInputs",
    "joint_inputs",
    "joint_limits",
    "resolve_robot",
    "spline_inputs",
    "trajectory_response",
]
