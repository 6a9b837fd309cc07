"""Forward kinematics and Jacobians of ``Robot``: pinocchio for one configuration, the vectorized
``Chain`` for many (tested equal), CasADi for the NLP.

Conventions: ``T_base_tool`` is the tool frame (the tip, or the tool frame of a TCP offset) in the
base frame (4x4, meters); the Jacobian is ``(6, dof)`` in the base frame, linear rows first.
"""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca
import numpy as np
import pinocchio as pin

from core.kinematics import task_rows
from robots.robot_data import RobotData
from robots.symbolic import fk_casadi


class ForwardKinematics(RobotData):
    """FK, Jacobians and the measures built on them."""

    def fk(self, q: np.ndarray) -> np.ndarray:
        """``T_base_tool`` (4, 4) at joint positions ``q`` (dof,)."""
        data = pin.Data(self._model)
        pin.forwardKinematics(self._model, data, self._q(q))
        T = pin.updateFramePlacement(self._model, data, self._tip_id).homogeneous
        return T if self._world_is_base else self._T_base_world @ T

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        """``T_base_tool`` for each row of ``qs`` (N, dof): (N, 4, 4). Vectorized numpy."""
        return self._chain.fk_many(self._rows(qs, "fk_many"))

    def fk_casadi(self) -> ca.Function:
        """FK as a ``casadi.Function`` ``fk(q) -> (p, R)`` (``robots.symbolic.fk_casadi``, built
        once per robot): the ``core.kinematics.SymbolicKinematics`` member the NLP uses."""
        return fk_casadi(self)  # type: ignore[arg-type]

    def fk_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(fk(q), jacobian(q))`` from one pinocchio pass (its frame Jacobian updates the tip's
        placement too): the cost of either alone, for a control tick that needs both."""
        return self._fk_jacobian(pin.Data(self._model), q)

    def fk_jacobian_loop(self) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """``fk_jacobian`` for a loop in one thread (a control run): the function it returns
        reuses one ``pin.Data`` of its own instead of a fresh one per call (allocating and freeing
        it costs more than the kinematics, measured: 83 against 57 us for a whole UR5 control
        tick). Each call returns new arrays; never share the function between threads.

        The function takes ``q`` as the loop's own float array (dof,): no conversion or size check
        of its own (pinocchio raises on a wrong size), and with the base at the world origin it
        calls pinocchio directly (about 0.7 of the 1.7 us a call is this method's layers)."""
        data = pin.Data(self._model)
        if not self._world_is_base:
            return lambda q: self._fk_jacobian(data, q)
        model, tip, frame = self._model, self._tip_id, pin.LOCAL_WORLD_ALIGNED
        jacobian, placements = pin.computeFrameJacobian, data.oMf

        def fk_jacobian(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            J = jacobian(model, data, q, tip, frame)  # (6, nv), a copy; updates oMf[tip] too
            return placements[tip].homogeneous, J

        return fk_jacobian

    def _fk_jacobian(self, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        J = pin.computeFrameJacobian(
            self._model, data, self._q(q), self._tip_id, pin.LOCAL_WORLD_ALIGNED
        ).reshape(6, self._model.nv)
        T = data.oMf[self._tip_id].homogeneous  # both are copies, not views into data
        if self._world_is_base:
            return T, J
        R = self._T_base_world[:3, :3]
        return self._T_base_world @ T, np.vstack([R @ J[:3], R @ J[3:]])

    def fk_jacobian_many(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(fk_many(qs), jacobian_many(qs))``, (N, 4, 4) and (N, 6, dof), from one product."""
        return self._chain.fk_jacobian_many(self._rows(qs, "fk_jacobian_many"))

    def jacobian_many(self, qs: np.ndarray) -> np.ndarray:
        """Tool Jacobians (N, 6, dof) in the base frame for each row of ``qs`` (N, dof), linear rows
        first: ``jacobian`` for many configurations at once (vectorized numpy, tested equal)."""
        return self._chain.fk_jacobian_many(self._rows(qs, "jacobian_many"))[1]

    def jacobian(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        """Geometric Jacobian (6, dof) of the tool (or ``frame``) in the base frame, linear rows
        first."""
        fid = self._tip_id if frame is None else self._frame_id(frame)
        data = pin.Data(self._model)
        J = pin.computeFrameJacobian(self._model, data, self._q(q), fid, pin.LOCAL_WORLD_ALIGNED)
        J = J.reshape(6, self._model.nv)  # eigenpy gives a 1-joint Jacobian as a (6,) array
        if not self._world_is_base:
            R = self._T_base_world[:3, :3]
            J = np.vstack([R @ J[:3], R @ J[3:]])
        return J

    def singular_values(self, q: np.ndarray, jacobian: np.ndarray | None = None) -> np.ndarray:
        """Singular values of the task rows of the Jacobian, descending, one per task row (6 for
        ``pose``, 2 for ``position_xy``): zeros pad them when the robot has fewer joints than rows,
        so that their product is sqrt(det(J J^T))."""
        J = self.jacobian(q) if jacobian is None else jacobian
        rows = task_rows(self._task_space)
        s = np.linalg.svd(J[rows], compute_uv=False)
        return np.concatenate([s, np.zeros(len(rows) - len(s))])

    def manipulability(self, q: np.ndarray, jacobian: np.ndarray | None = None) -> float:
        """Yoshikawa's manipulability sqrt(det(J J^T)) over the task rows."""
        return float(np.prod(self.singular_values(q, jacobian)))
