"""Robot: a pinocchio model of a serial chain with its frames and limits; FK, Jacobian, IK.

``Robot`` satisfies ``core.kinematics.Kinematics``. It holds only read-only data: every pinocchio call
gets a fresh ``pin.Data`` (about 6 us), so one ``Robot`` serves concurrent requests from any number of
threads. Its methods come from one module per concept: ``robots.forward`` (FK, Jacobians; the
vectorized ``robots.chain.Chain``, tested equal to pinocchio), ``robots.frames`` (link frames, reach),
``robots.solving`` (IK, configuration labels); this module builds the model's data and holds the
description, the limits and the tool offset (``with_tool``, ``robots.tool``).

Conventions: ``T_base_tool`` is the tool frame in the base frame (4x4, meters): the tip frame, or
with a tool offset the tool frame on it; the Jacobian is ``(6, dof)`` in the base frame, linear rows
first; joint positions in [rad] (revolute) or [m] (prismatic), in ``joint_names`` order.
"""

from __future__ import annotations

import copy
import threading
from collections import OrderedDict
from collections.abc import Mapping
from types import MappingProxyType

import numpy as np
import pinocchio as pin

from core.kinematics import TASK_SPACES, task_rows
from robots import configurations as _configurations
from robots import ik_analytic as _ik_analytic
from robots import tool as _tool
from robots.chain import Chain
from robots.dynamics import RigidBodyDynamics, effort_limits
from robots.forward import ForwardKinematics
from robots.frames import Frames
from robots.robot_data import ClosedFormIK
from robots.solving import InverseKinematics

__all__ = ["ClosedFormIK", "Robot"]

TOOL_CACHE = 16
"""Tool offsets kept per robot (``with_tool``: a request's tool is usually one of a few)."""


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


class Robot(ForwardKinematics, Frames, InverseKinematics):
    """A robot's kinematics.

    Args:
        name: Registered name, or ``inline-<hash>`` for a client URDF.
        model: pinocchio model holding exactly the chain's movable joints (one dof each).
        base_frame: Frame (link) of the base; fixed to the model's root.
        tip_frame: Frame (link) of the tool.
        task_space: ``"pose"`` or ``"position_xy"``.
        acceleration_limits: ``(dof,)`` [rad/s^2 or m/s^2], > 0.
        velocity_limits: ``(dof,)`` [rad/s or m/s], > 0; default the model's (URDF) velocity limits.
        home: ``(dof,)`` a configuration away from singularities; default zeros clipped into the limits.
        closed_form_ik: Analytic IK for ``position_xy`` arms (see ``robots.ik_numeric.planar_2r``).
        redundant_joints: Joints held by IK (7-joint arms); default: for 7 revolute joints the
            first joint from the tip whose holding lets EAIK solve the other six, else the last
            ``dof - task rows`` joints.
        sources: Where each kind of limit comes from (``"position"``, ``"velocity"``, ...).
        jerk_limits: ``(dof,)`` [rad/s^3 or m/s^3], > 0, or ``None`` where the maker publishes none.
        with_dynamics: The model's inertias are known (``robots.dynamics``): ``dynamics`` is set.
    """

    def __init__(
        self,
        name: str,
        model: pin.Model,
        *,
        base_frame: str,
        tip_frame: str,
        task_space: str,
        acceleration_limits: np.ndarray,
        velocity_limits: np.ndarray | None = None,
        home: np.ndarray | None = None,
        closed_form_ik: ClosedFormIK | None = None,
        sources: Mapping[str, str] | None = None,
        redundant_joints: tuple[str, ...] | None = None,
        jerk_limits: np.ndarray | None = None,
        with_dynamics: bool = False,
    ) -> None:
        if task_space not in TASK_SPACES:
            raise ValueError(f"task_space must be one of {TASK_SPACES}")
        self._name, self._model, self._task_space = name, model, task_space
        self._base_frame, self._tip_frame = base_frame, tip_frame
        self._tip_id = model.getFrameId(tip_frame, pin.FrameType.BODY)
        self._base_id = model.getFrameId(base_frame, pin.FrameType.BODY)
        self._chain = Chain.from_model(model, self._tip_id, self._base_id)
        if len(self._chain.q_index) != model.nq or model.nq != model.nv:
            raise ValueError("the model must hold exactly the chain's one-dof joints")
        self._joint_names = tuple(model.names[1:])
        self._limits = _ro(np.column_stack([model.lowerPositionLimit, model.upperPositionLimit]))
        revolute = np.zeros(model.nq, dtype=bool)
        revolute[self._chain.q_index] = self._chain.revolute
        self._revolute = revolute
        self._revolute.flags.writeable = False
        self._set_limits(model, velocity_limits, acceleration_limits, jerk_limits, home)
        self._T_base_world = self._chain.T_base_world
        self._SE3_world_base = pin.SE3(np.linalg.inv(self._T_base_world))
        self._world_is_base = bool(np.allclose(self._T_base_world, np.eye(4), atol=0, rtol=0))
        self._closed_form = closed_form_ik
        self.sources: Mapping[str, str] = MappingProxyType(dict(sources or {}))
        self._set_redundancy(redundant_joints)
        self._family = _configurations.family(self._chain, task_space)
        R_world_base = self._T_base_world[:3, :3].T
        self._dynamics = RigidBodyDynamics(model, R_world_base) if with_dynamics else None
        self._effort = effort_limits(model)
        self._arm: Robot = self
        self._tool: np.ndarray | None = None
        self._tools: OrderedDict[bytes, Robot] = OrderedDict()
        self._tools_lock = threading.Lock()

    def _set_limits(
        self,
        model: pin.Model,
        velocity: np.ndarray | None,
        acceleration: np.ndarray,
        jerk: np.ndarray | None,
        home: np.ndarray | None,
    ) -> None:
        self._velocity = _ro(model.velocityLimit if velocity is None else velocity)
        self._acceleration = _ro(acceleration)
        self._jerk = None if jerk is None else _ro(jerk)
        home = np.zeros(model.nq) if home is None else home
        self._home = _ro(np.clip(home, self._limits[:, 0], self._limits[:, 1]))
        for arr, what in ((self._velocity, "velocity"), (self._acceleration, "acceleration")):
            if arr.shape != (model.nq,) or not np.all(np.isfinite(arr) & (arr > 0)):
                raise ValueError(f"{what} limits must be {model.nq} finite values > 0")

    def _set_redundancy(self, redundant_joints: tuple[str, ...] | None) -> None:
        """The analytic solver and the joints IK holds (see the class docstring)."""
        nq = self._model.nq
        self._task_rows = task_rows(self._task_space)
        extra = max(0, nq - len(self._task_rows))
        if redundant_joints is not None:
            order = tuple(self._joint_names.index(n) for n in redundant_joints)
        else:
            order = tuple(range(nq - 1, -1, -1))
        pose = self._task_space == "pose"
        self._analytic = _ik_analytic.build(self._chain, order) if pose else None
        if self._analytic is not None and self._analytic.held is not None:
            held: tuple[int, ...] = (self._analytic.held,)
        elif redundant_joints is not None:
            held = order
        else:
            held = tuple(range(nq - extra, nq))
        self._redundant = tuple(self._joint_names[j] for j in sorted(held))

    # --- the tool offset ------------------------------------------------------------------------
    @property
    def arm(self) -> Robot:
        """The robot without a tool offset (itself when it has none)."""
        return self._arm

    @property
    def tool(self) -> np.ndarray | None:
        """``T_tip_tool`` (4, 4): the tool frame in the tip frame, or None without a tool offset."""
        return self._tool

    def with_tool(self, T_tip_tool: np.ndarray) -> Robot:
        """This robot answering for the tool frame ``T_tip_tool`` (4, 4) on its tip: FK, Jacobians,
        IK, configuration labels and the reach refer to it (``robots.tool``). Checked
        (``InputError`` at ``tool``), built once per offset (a few kept per robot)."""
        T = _tool.check_tool(T_tip_tool)
        arm = self._arm
        key = T.tobytes()
        with arm._tools_lock:
            hit = arm._tools.get(key)
            if hit is not None:
                arm._tools.move_to_end(key)
                return hit
        tooled = copy.copy(arm)
        tip = arm._tip_id
        tooled._model, tooled._tip_id = _tool.model_with_tool(arm._model, tip, T)
        tooled._chain = Chain.from_model(tooled._model, tooled._tip_id, arm._base_id)
        tooled._tool = T.copy()
        tooled._tool.flags.writeable = False
        if arm._analytic is not None:
            tooled._analytic = arm._analytic.with_tool(T)
        if arm._closed_form is not None:
            lo, hi = arm._limits[:, 0], arm._limits[:, 1]
            tooled._closed_form = _tool.planar_closed_form(tooled._chain, lo, hi)
        tooled._family = _configurations.family(tooled._chain, arm._task_space)
        with arm._tools_lock:
            arm._tools[key] = tooled
            while len(arm._tools) > TOOL_CACHE:
                arm._tools.popitem(last=False)
        return tooled

    # --- description --------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._name

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._joint_names

    @property
    def dof(self) -> int:
        return int(self._model.nq)

    @property
    def task_space(self) -> str:
        """``"pose"`` or ``"position_xy"``."""
        return self._task_space

    @property
    def position_limits(self) -> np.ndarray:
        """``(dof, 2)`` lower and upper joint position limits [rad or m]."""
        return self._limits

    @property
    def velocity_limits(self) -> np.ndarray:
        """``(dof,)`` joint speed limits [rad/s or m/s], > 0."""
        return self._velocity

    @property
    def acceleration_limits(self) -> np.ndarray:
        """``(dof,)`` joint acceleration limits [rad/s^2 or m/s^2], > 0."""
        return self._acceleration

    @property
    def jerk_limits(self) -> np.ndarray | None:
        """``(dof,)`` joint jerk limits [rad/s^3 or m/s^3], or ``None`` when not published."""
        return self._jerk

    @property
    def effort_limits(self) -> np.ndarray | None:
        """``(dof,)`` joint effort limits [N m or N] from the URDF, or ``None`` when not known."""
        return self._effort

    @property
    def dynamics(self) -> RigidBodyDynamics | None:
        """Inverse dynamics (``core.kinematics.Dynamics``), or ``None`` without inertias."""
        return self._dynamics

    @property
    def home(self) -> np.ndarray:
        """``(dof,)`` a configuration inside the limits, away from singularities."""
        return self._home

    @property
    def base_frame(self) -> str:
        return self._base_frame

    @property
    def tip_frame(self) -> str:
        """The tip link (a tool offset is expressed in its frame)."""
        return self._tip_frame

    @property
    def revolute(self) -> np.ndarray:
        """``(dof,)`` True for revolute joints, False for prismatic ones."""
        return self._revolute

    @property
    def chain(self) -> Chain:
        """The chain's constant data (base to tool frame), for vectorized and symbolic FK."""
        return self._chain

    @property
    def model(self) -> pin.Model:
        """The pinocchio model; read-only by convention (create a ``pin.Data`` per use)."""
        return self._model

    @property
    def task_rows(self) -> list[int]:
        """Rows of the 6-row Jacobian the task space uses."""
        return list(self._task_rows)

    @property
    def redundant_joints(self) -> tuple[str, ...]:
        """Joints IK holds (at ``fixed_joints``, else the seed's value); empty for 6R arms."""
        return self._redundant

    def __repr__(self) -> str:
        tool = "" if self._tool is None else ", tool offset"
        return f"Robot({self._name!r}, dof={self.dof}, task_space={self._task_space!r}{tool})"
