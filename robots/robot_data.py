"""The fields every part of ``robots.model.Robot`` reads, declared once (set by ``Robot.__init__``).

``Robot`` is assembled from one mixin per concept (``robots.forward``: FK and Jacobians,
``robots.frames``: link frames and reach, ``robots.solving``: IK and configuration labels), each
reading these fields; ``robots.model`` builds them from the pinocchio model and adds the
description, the limits and the tool offset.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from core.errors import InputError, UnknownFrame
from robots.chain import Chain
from robots.ik_analytic import AnalyticIK

ClosedFormIK = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, bool]]
"""(goal x, y in the base frame [m], seed (dof,)) -> (joint positions, inside the limits)."""


class RobotData:
    """Read-only state of a robot (every pinocchio call gets a fresh ``pin.Data``).

    Attributes:
        _model: The pinocchio model (with a tool offset: a copy holding the tool frame).
        _tip_id: The frame FK and IK answer for (the tip, or the tool frame on it).
        _chain: The base -> tool chain (``Chain``), for vectorized and symbolic FK.
        _T_base_world: ``(4, 4)`` the model's world frame in the base frame.
        _limits: ``(dof, 2)`` position limits; ``_revolute``: ``(dof,)``.
    """

    _name: str
    _model: pin.Model
    _task_space: str
    _tip_id: int
    _chain: Chain
    _limits: np.ndarray
    _revolute: np.ndarray
    _home: np.ndarray
    _T_base_world: np.ndarray
    _SE3_world_base: pin.SE3
    _world_is_base: bool
    _closed_form: ClosedFormIK | None
    _analytic: AnalyticIK | None
    _family: str | None

    def _q(self, q: np.ndarray, field: str = "positions") -> np.ndarray:
        """``q`` as a float array of the robot's dof; ``InputError`` at ``field`` otherwise."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self._model.nq,):
            raise InputError(
                f"{field} needs {self._model.nq} values (one per joint of {self._name})",
                field=(field,),
            )
        return q

    def _rows(self, qs: np.ndarray, what: str) -> np.ndarray:
        """``qs`` as a float ``(N, dof)`` array; ``InputError`` at ``positions`` otherwise."""
        qs = np.asarray(qs, dtype=float)
        if qs.ndim != 2 or qs.shape[1] != self._model.nq:
            raise InputError(f"{what} needs an (N, {self._model.nq}) array", field=("positions",))
        return qs

    def frame_names(self) -> list[str]:
        """Names of the model's link frames."""
        return [f.name for f in self._model.frames if f.type == pin.FrameType.BODY]

    def _frame_id(self, frame: str) -> int:
        """The id of link frame ``frame``; ``UnknownFrame`` lists the frames."""
        if frame not in self.frame_names():
            raise UnknownFrame(
                f"{self._name} has no frame of that name",
                field=("frame",),
                extra={"frames": self.frame_names()},
            )
        return int(self._model.getFrameId(frame, pin.FrameType.BODY))
