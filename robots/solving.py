"""Inverse kinematics of ``Robot`` and its configuration labels: the glue between the robot's data
and the solvers (``robots.ik``: every solution, ``robots.ik_batch``: many poses, ``robots.ik_retry``:
one solution with a second effort, ``robots.ik_numeric``: damped Newton, ``robots.ik_analytic``:
EAIK, ``robots.configurations``: labels)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from core.budget import NO_DEADLINE, Deadline
from core.errors import InputError
from core.kinematics import IKResult
from robots import configurations as _configurations
from robots import ik as _ik
from robots import ik_batch as _ik_batch
from robots import ik_numeric as _ik_numeric
from robots import ik_retry as _ik_retry
from robots.ik_analytic import AnalyticIK
from robots.robot_data import ClosedFormIK, RobotData


class InverseKinematics(RobotData):
    """IK (one solution, every solution, many poses) and configuration labels."""

    @property
    def analytic_ik(self) -> AnalyticIK | None:
        """The EAIK solver of this chain, or None when none applies."""
        return self._analytic

    @property
    def planar_closed_form(self) -> ClosedFormIK | None:
        return self._closed_form

    @property
    def ik_solver(self) -> str:
        """``"analytic"`` or ``"numeric"``: what ``ik_all`` uses."""
        return "analytic" if (self._analytic or self._closed_form) is not None else "numeric"

    @property
    def max_solutions(self) -> int | None:
        """Most distinct solutions of one pose (without 2 pi turns), where the family fixes it."""
        if self._family == _configurations.WRIST_6R:
            return 8
        if self._family == _configurations.PLANAR_2R:
            return 2
        return None

    @property
    def configuration_family(self) -> str | None:
        """``"wrist_6r"``, ``"planar_2r"`` or None (see ``robots.configurations``)."""
        return self._family

    @property
    def configuration_labels(self) -> tuple[str, ...]:
        """Every label this robot's solutions can carry (empty without a family)."""
        return _configurations.LABELS.get(self._family, ()) if self._family else ()

    def configurations(self, qs: np.ndarray) -> list[str | None]:
        """The configuration label of each row of ``qs`` ``(N, dof)``."""
        return _configurations.labels(self._chain, self._family, qs)

    def configuration(self, q: np.ndarray) -> str | None:
        """The configuration label of ``q`` ``(dof,)`` (None for robots without labels)."""
        return self.configurations(self._q(q)[None])[0]

    def ik_all(
        self,
        T_base_tool: np.ndarray,
        seed: np.ndarray | None = None,
        fixed_joints: Mapping[str, float] | None = None,
        turns: bool = False,
    ) -> _ik.IKSolutions:
        """Every IK solution of ``T_base_tool`` inside the limits, verified to 1e-9 m and 1e-9 rad,
        nearest ``seed`` (default home) first; see ``robots.ik.ik_all``."""
        return _ik.ik_all(self, T_base_tool, seed, dict(fixed_joints or {}), turns)  # type: ignore[arg-type]

    def ik_one(
        self,
        T_base_tool: np.ndarray,
        seed: np.ndarray | None = None,
        fixed_joints: Mapping[str, float] | None = None,
        configuration: str | None = None,
        deadline: Deadline = NO_DEADLINE,
    ) -> _ik.IKSolutions:
        """What the single-solution IK answers from: ``ik_all``, and when none of its solutions has
        ``configuration``, a second effort (redundant joints the request does not fix released,
        more starts) bounded by ``deadline``; see ``robots.ik_retry``."""
        return _ik_retry.ik_one(
            self,  # type: ignore[arg-type]
            T_base_tool, seed, dict(fixed_joints or {}), configuration, deadline,
        )  # fmt: skip

    def _poses(self, Ts: np.ndarray, what: str) -> np.ndarray:
        Ts = np.asarray(Ts, dtype=float)
        if Ts.ndim != 3 or Ts.shape[1:] != (4, 4) or not np.isfinite(Ts).all():
            raise InputError(f"{what} needs finite (N, 4, 4) poses", field=("pose",))
        return Ts

    def ik_all_many(self, Ts: np.ndarray, seed: np.ndarray | None = None) -> list[_ik.IKSolutions]:
        """``ik_all`` for many poses ``(N, 4, 4)`` at once (batched for analytic 6R arms)."""
        Ts = self._poses(Ts, "ik_all_many")
        seed_q = None if seed is None else self._q(seed, "seed")
        return _ik_batch.ik_all_many(self, Ts, seed_q)  # type: ignore[arg-type]

    def ik_many(
        self, Ts: np.ndarray, seed: np.ndarray, configuration: str | None = None
    ) -> _ik_batch.IKPath:
        """IK of many poses ``(N, 4, 4)`` on one configuration branch (default the seed's label),
        batched for analytic 6R arms; see ``robots.ik_batch.ik_many``."""
        Ts = self._poses(Ts, "ik_many")
        if configuration is not None and configuration not in self.configuration_labels:
            raise InputError(
                "unknown configuration label",
                field=("configuration",),
                extra={"configurations": list(self.configuration_labels)},
            )
        return _ik_batch.ik_many(self, Ts, self._q(seed, "seed"), configuration)  # type: ignore[arg-type]

    def ik_from(
        self,
        T_base_tool: np.ndarray,
        start: np.ndarray,
        limits: tuple[np.ndarray, np.ndarray, np.ndarray],
        *,
        max_iterations: int,
        tolerance: float,
        respect_limits: bool = True,
    ) -> IKResult:
        """Damped Newton from ``start`` with explicit ``limits`` (lower, upper, revolute mask); a
        joint with lower == upper is held."""
        T = np.asarray(T_base_tool, dtype=float)
        return self._newton(T, start, limits, max_iterations, tolerance, tolerance, respect_limits)

    def _newton(
        self,
        T: np.ndarray,
        start: np.ndarray,
        limits: tuple[np.ndarray, np.ndarray, np.ndarray],
        max_iterations: int,
        position_tolerance: float,
        orientation_tolerance: float,
        respect_limits: bool,
    ) -> IKResult:
        """``robots.ik_numeric`` on the tool frame: x and y only for ``position_xy`` robots."""
        options = {
            "max_iterations": int(max_iterations),
            "position_tolerance": float(position_tolerance),
            "orientation_tolerance": float(orientation_tolerance),
            "respect_limits": respect_limits,
        }
        if self._task_space == "position_xy":
            return _ik_numeric.solve_position_xy(
                self._model, self._tip_id, self._T_base_world, T[:2, 3], start, limits, **options
            )
        goal = self._SE3_world_base * pin.SE3(T[:3, :3], T[:3, 3])
        return _ik_numeric.solve_pose(self._model, self._tip_id, goal, start, limits, **options)

    def ik(
        self,
        T_base_tool: np.ndarray,
        seed: np.ndarray,
        *,
        max_iterations: int = 100,
        position_tolerance: float = 1e-6,
        orientation_tolerance: float = 1e-6,
        respect_limits: bool = True,
    ) -> IKResult:
        """Joint positions whose tool pose is ``T_base_tool``, from (and near) ``seed`` (dof,).

        ``pose`` robots: Levenberg-Marquardt on the SE3 log error; ``position_xy`` robots: only x and
        y count (closed form when the robot has one). Converged means within ``position_tolerance``
        [m] and ``orientation_tolerance`` [rad]; ``success`` also needs the joint limits respected.
        Never raises for non-convergence: ``success`` is False and the residuals are honest.
        ``respect_limits=False`` lets the iteration leave the limits (to diagnose a goal reachable
        only outside them).
        """
        T = np.asarray(T_base_tool, dtype=float)
        seed = self._q(seed, "seed")
        if T.shape != (4, 4) or not (np.isfinite(T).all() and np.isfinite(seed).all()):
            raise InputError("IK needs a finite 4x4 T_base_tool and a finite seed", field=("pose",))
        if self._task_space == "position_xy" and self._closed_form is not None:
            q, inside = self._closed_form(T[:2, 3], seed)
            err = float(np.linalg.norm(self._chain.fk_many(q[None])[0, :2, 3] - T[:2, 3]))
            ok = bool(inside and err <= position_tolerance)
            return IKResult(q, ok, err, 0.0, 1, bool(inside))
        limits = (self._limits[:, 0], self._limits[:, 1], self._revolute)
        return self._newton(T, seed, limits, max_iterations, position_tolerance,
                            orientation_tolerance, respect_limits)  # fmt: skip
