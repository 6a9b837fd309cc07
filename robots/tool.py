"""A tool offset (TCP): the tool frame's pose ``T_tip_tool`` in the robot's tip frame.

``Robot.with_tool(T_tip_tool)`` is the same robot answering for the tool frame: its pinocchio model is
a copy holding one more (operational) frame at ``tip * T_tip_tool`` on the tip's joint, and FK,
Jacobians, the vectorized and symbolic chains, numeric IK, configuration labels and the reach all
follow that frame. Analytic IK keeps the flange's solvers and is given the flange pose a tool pose
needs (EAIK: ``robots.ik_analytic.AnalyticIK.with_tool``; the planar 2-link arm: ``planar_2r`` on
the arm whose second link ends at the tool point). The collision geometry is the arm's: a tool
frame carries none.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from core.errors import InputError
from robots.chain import Chain
from robots.ik_numeric import planar_2r, planar_2r_geometry
from robots.robot_data import ClosedFormIK

MAX_TOOL_OFFSET = 10.0
"""[m] Largest tool offset from the tip (each coordinate)."""
ROTATION_TOLERANCE = 1e-9
"""Largest deviation of ``T_tip_tool``'s rotation from orthonormal (|R^T R - I|, |det R - 1|)."""
TOOL_FRAME = "tool (tcp)"
"""Name of the tool frame added to a robot's model (an operational frame, never a link)."""


def check_tool(T_tip_tool: np.ndarray) -> np.ndarray:
    """``T_tip_tool`` as a float ``(4, 4)`` rigid transform; ``InputError`` at ``tool.position``
    (finite, each |coordinate| <= ``MAX_TOOL_OFFSET``) or ``tool.orientation`` (a rotation)."""
    T = np.asarray(T_tip_tool, dtype=float)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise InputError("tool needs a finite 4x4 transform", field=("tool",))
    if np.abs(T[:3, 3]).max() > MAX_TOOL_OFFSET:
        raise InputError(
            f"tool.position must be within {MAX_TOOL_OFFSET:g} m of the tip in every coordinate",
            field=("tool", "position"),
        )
    R = T[:3, :3]
    bad_rotation = np.abs(R.T @ R - np.eye(3)).max() > ROTATION_TOLERANCE
    if bad_rotation or abs(np.linalg.det(R) - 1.0) > ROTATION_TOLERANCE:
        raise InputError("tool.orientation must be a rotation", field=("tool", "orientation"))
    if not np.array_equal(T[3], [0.0, 0.0, 0.0, 1.0]):
        raise InputError("tool needs a homogeneous transform (last row 0 0 0 1)", field=("tool",))
    return T


def model_with_tool(model: pin.Model, tip_id: int, T_tip_tool: np.ndarray) -> tuple[pin.Model, int]:
    """A copy of ``model`` with the tool frame on the tip's joint, and that frame's id."""
    out = pin.Model(model)
    tip = out.frames[tip_id]
    placement = tip.placement * pin.SE3(T_tip_tool[:3, :3], T_tip_tool[:3, 3])
    frame = pin.Frame(TOOL_FRAME, tip.parentJoint, tip_id, placement, pin.FrameType.OP_FRAME)
    return out, int(out.addFrame(frame, False))


def planar_closed_form(chain: Chain, lower: np.ndarray, upper: np.ndarray) -> ClosedFormIK | None:
    """The closed-form IK of a planar 2R chain about +z axes, built from the chain itself (the
    tool point included, ``planar_2r_geometry``): ``planar_2r`` on the arm whose second link ends
    at the chain's tip, the links' angles at q = 0 as offsets. None for other chains."""
    geometry = planar_2r_geometry(chain)
    if geometry is None:
        return None
    o1, l1, l2, offset = geometry

    def solve(goal_xy: np.ndarray, seed: np.ndarray) -> tuple[np.ndarray, bool]:
        q, inside = planar_2r(
            np.asarray(goal_xy, dtype=float) - o1, seed + offset, l1, l2, lower + offset,
            upper + offset,
        )  # fmt: skip
        return q - offset, inside

    return solve
