"""What the IK solvers (``robots.ik``, ``robots.ik_batch``, ``robots.ik_retry``) read of a robot: a
Protocol, so they depend on no concrete class (``robots.model.Robot`` satisfies it and imports
them)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from core.kinematics import IKResult
from robots.chain import Chain
from robots.ik_analytic import AnalyticIK
from robots.robot_data import ClosedFormIK


class IKRobot(Protocol):
    """The robot members the IK solvers use (see ``robots.model.Robot`` for their meaning)."""

    @property
    def name(self) -> str: ...

    @property
    def dof(self) -> int: ...

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def task_space(self) -> str: ...

    @property
    def task_rows(self) -> list[int]: ...

    @property
    def position_limits(self) -> np.ndarray: ...

    @property
    def revolute(self) -> np.ndarray: ...

    @property
    def home(self) -> np.ndarray: ...

    @property
    def chain(self) -> Chain: ...

    @property
    def redundant_joints(self) -> tuple[str, ...]: ...

    @property
    def analytic_ik(self) -> AnalyticIK | None: ...

    @property
    def planar_closed_form(self) -> ClosedFormIK | None: ...

    @property
    def configuration_family(self) -> str | None: ...

    def configuration(self, q: np.ndarray) -> str | None: ...

    def configurations(self, qs: np.ndarray) -> list[str | None]: ...

    def reach_bound(self) -> float: ...

    def reach_distance(self, T_base_tool: np.ndarray) -> float: ...

    def ik(
        self,
        T_base_tool: np.ndarray,
        seed: np.ndarray,
        *,
        max_iterations: int = 100,
        position_tolerance: float = 1e-6,
        orientation_tolerance: float = 1e-6,
        respect_limits: bool = True,
    ) -> IKResult: ...

    def ik_from(
        self,
        T_base_tool: np.ndarray,
        start: np.ndarray,
        limits: tuple[np.ndarray, np.ndarray, np.ndarray],
        *,
        max_iterations: int,
        tolerance: float,
        respect_limits: bool = True,
    ) -> IKResult: ...
