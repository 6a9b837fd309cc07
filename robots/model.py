"""Robot: a pinocchio model of a serial chain with its frames and limits; FK, Jacobian, IK.

``Robot`` satisfies ``core.kinematics.Kinematics``. It holds only read-only data: every pinocchio call
gets a fresh ``pin.Data`` (about 6 us), so one ``Robot`` serves concurrent requests from any number of
threads. ``fk_many`` uses a vectorized numpy product of joint transforms (``robots.chain.Chain``),
extracted once from the model and tested equal to pinocchio.

Conventions: ``T_base_tool`` is the tip frame in the base frame (4x4, meters); the Jacobian is
``(6, dof)`` in the base frame, linear rows first; joint positions in [rad] (revolute) or [m]
(prismatic), in ``joint_names`` order.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType

import casadi as ca
import numpy as np
import pinocchio as pin

from core.budget import NO_DEADLINE, Deadline
from core.errors import InputError, UnknownFrame
from core.kinematics import TASK_SPACES, IKResult, task_rows
from robots import configurations as _configurations
from robots import ik as _ik
from robots import ik_analytic as _ik_analytic
from robots import ik_numeric as _ik_numeric
from robots import ik_retry as _ik_retry
from robots.chain import Chain
from robots.dynamics import RigidBodyDynamics, effort_limits
from robots.symbolic import fk_casadi

ClosedFormIK = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, bool]]
"""(goal x, y in the base frame [m], seed (dof,)) -> (joint positions, inside the limits)."""


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


class Robot:
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
        vel = model.velocityLimit if velocity_limits is None else velocity_limits
        self._velocity = _ro(vel)
        self._acceleration = _ro(acceleration_limits)
        self._jerk = None if jerk_limits is None else _ro(jerk_limits)
        home = np.zeros(model.nq) if home is None else home
        self._home = _ro(np.clip(home, self._limits[:, 0], self._limits[:, 1]))
        for arr, what in ((self._velocity, "velocity"), (self._acceleration, "acceleration")):
            if arr.shape != (model.nq,) or not np.all(np.isfinite(arr) & (arr > 0)):
                raise ValueError(f"{what} limits must be {model.nq} finite values > 0")
        self._T_base_world = self._chain.T_base_world
        self._SE3_world_base = pin.SE3(np.linalg.inv(self._T_base_world))
        self._world_is_base = bool(np.allclose(self._T_base_world, np.eye(4), atol=0, rtol=0))
        self._closed_form = closed_form_ik
        self.sources: Mapping[str, str] = MappingProxyType(dict(sources or {}))
        self._task_rows = task_rows(task_space)
        extra = max(0, model.nq - len(self._task_rows))
        if redundant_joints is not None:
            order = tuple(self._joint_names.index(n) for n in redundant_joints)
        else:
            order = tuple(range(model.nq - 1, -1, -1))
        self._analytic = _ik_analytic.build(self._chain, order) if task_space == "pose" else None
        if self._analytic is not None and self._analytic.held is not None:
            held: tuple[int, ...] = (self._analytic.held,)
        elif redundant_joints is not None:
            held = order
        else:
            held = tuple(range(model.nq - extra, model.nq))
        self._redundant = tuple(self._joint_names[j] for j in sorted(held))
        self._family = _configurations.family(self._chain, task_space)
        R_world_base = self._T_base_world[:3, :3].T
        self._dynamics = RigidBodyDynamics(model, R_world_base) if with_dynamics else None
        self._effort = effort_limits(model)

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
        return self._tip_frame

    @property
    def revolute(self) -> np.ndarray:
        """``(dof,)`` True for revolute joints, False for prismatic ones."""
        return self._revolute

    @property
    def chain(self) -> Chain:
        """The chain's constant data, for vectorized and symbolic FK."""
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

    @property
    def analytic_ik(self) -> _ik_analytic.AnalyticIK | None:
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
        return _ik.ik_all(self, T_base_tool, seed, dict(fixed_joints or {}), turns)

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
            self, T_base_tool, seed, dict(fixed_joints or {}), configuration, deadline
        )

    def ik_all_many(self, Ts: np.ndarray, seed: np.ndarray | None = None) -> list[_ik.IKSolutions]:
        """``ik_all`` for many poses ``(N, 4, 4)`` at once (batched for analytic 6R arms)."""
        Ts = np.asarray(Ts, dtype=float)
        if Ts.ndim != 3 or Ts.shape[1:] != (4, 4) or not np.isfinite(Ts).all():
            raise InputError("ik_all_many needs finite (N, 4, 4) poses", field=("pose",))
        return _ik.ik_all_many(self, Ts, None if seed is None else self._q(seed, "seed"))

    def ik_many(
        self, Ts: np.ndarray, seed: np.ndarray, configuration: str | None = None
    ) -> _ik.IKPath:
        """IK of many poses ``(N, 4, 4)`` on one configuration branch (default the seed's label),
        batched for analytic 6R arms; see ``robots.ik.ik_many``."""
        Ts = np.asarray(Ts, dtype=float)
        if Ts.ndim != 3 or Ts.shape[1:] != (4, 4) or not np.isfinite(Ts).all():
            raise InputError("ik_many needs finite (N, 4, 4) poses", field=("pose",))
        if configuration is not None and configuration not in self.configuration_labels:
            raise InputError(
                "unknown configuration label",
                field=("configuration",),
                extra={"configurations": list(self.configuration_labels)},
            )
        return _ik.ik_many(self, Ts, self._q(seed, "seed"), configuration)

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
        options = {
            "max_iterations": max_iterations,
            "position_tolerance": tolerance,
            "orientation_tolerance": tolerance,
            "respect_limits": respect_limits,
        }
        T = np.asarray(T_base_tool, dtype=float)
        if self._task_space == "position_xy":
            return _ik_numeric.solve_position_xy(
                self._model, self._tip_id, self._T_base_world, T[:2, 3], start, limits, **options
            )
        goal = self._SE3_world_base * pin.SE3(T[:3, :3], T[:3, 3])
        return _ik_numeric.solve_pose(self._model, self._tip_id, goal, start, limits, **options)

    def frame_names(self) -> list[str]:
        """Names of the model's link frames."""
        return [f.name for f in self._model.frames if f.type == pin.FrameType.BODY]

    def _q(self, q: np.ndarray, field: str = "positions") -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self._model.nq,):
            raise InputError(
                f"{field} needs {self._model.nq} values (one per joint of {self._name})",
                field=(field,),
            )
        return q

    # --- kinematics ---------------------------------------------------------------------------
    def fk(self, q: np.ndarray) -> np.ndarray:
        """``T_base_tool`` (4, 4) at joint positions ``q`` (dof,)."""
        data = pin.Data(self._model)
        pin.forwardKinematics(self._model, data, self._q(q))
        T = pin.updateFramePlacement(self._model, data, self._tip_id).homogeneous
        return T if self._world_is_base else self._T_base_world @ T

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        """``T_base_tool`` for each row of ``qs`` (N, dof): (N, 4, 4). Vectorized numpy."""
        qs = np.asarray(qs, dtype=float)
        if qs.ndim != 2 or qs.shape[1] != self._model.nq:
            raise InputError(f"fk_many needs an (N, {self._model.nq}) array", field=("positions",))
        return self._chain.fk_many(qs)

    def fk_casadi(self) -> ca.Function:
        """FK as a ``casadi.Function`` ``fk(q) -> (p, R)`` (``robots.symbolic.fk_casadi``, built
        once per robot): the ``core.kinematics.SymbolicKinematics`` member the NLP uses."""
        return fk_casadi(self)

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
        qs = np.asarray(qs, dtype=float)
        if qs.ndim != 2 or qs.shape[1] != self._model.nq:
            raise InputError(
                f"fk_jacobian_many needs an (N, {self._model.nq}) array", field=("positions",)
            )
        return self._chain.fk_jacobian_many(qs)

    def jacobian_many(self, qs: np.ndarray) -> np.ndarray:
        """Tip Jacobians (N, 6, dof) in the base frame for each row of ``qs`` (N, dof), linear rows
        first: ``jacobian`` for many configurations at once (vectorized numpy, tested equal)."""
        qs = np.asarray(qs, dtype=float)
        if qs.ndim != 2 or qs.shape[1] != self._model.nq:
            raise InputError(
                f"jacobian_many needs an (N, {self._model.nq}) array", field=("positions",)
            )
        return self._chain.fk_jacobian_many(qs)[1]

    def frame_pose(self, q: np.ndarray, frame: str) -> np.ndarray:
        """``T_base_frame`` (4, 4) of any link frame; ``UnknownFrame`` lists the frames."""
        fid = self._frame_id(frame)
        data = pin.Data(self._model)
        pin.forwardKinematics(self._model, data, self._q(q))
        return self._T_base_world @ pin.updateFramePlacement(self._model, data, fid).homogeneous

    def reach_origin(self) -> np.ndarray:
        """A point on the first joint's axis (its origin) in the base frame [m]."""
        return np.array(self._chain.joint_axes_many(np.zeros((1, self.dof)))[1][0, 0])

    def reach_bound(self) -> float:
        """An upper bound [m] of the tip's distance from ``reach_origin``: the sum of the distances
        between consecutive joint origins and from the last one to the tip (prismatic joints add
        their largest extension)."""
        _, o, T = self._chain.joint_axes_many(np.zeros((1, self.dof)))
        pts = np.vstack([o[0], T[0, :3, 3]])
        travel = np.where(self._revolute, 0.0, np.abs(self._limits).max(axis=1)).sum()
        return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() + travel)

    def reach_distance(self, T_base_tool: np.ndarray) -> float:
        """The distance [m] of a tool pose's position from ``reach_origin``, to compare with
        ``reach_bound`` (in x and y only for a ``position_xy`` arm)."""
        axes = 2 if self.task_space == "position_xy" else 3
        offset = np.asarray(T_base_tool, dtype=float)[:3, 3] - self.reach_origin()
        return float(np.linalg.norm(offset[:axes]))

    def link_frames(self, q: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """Every link frame's name and ``T_base_frame`` (4, 4) at ``q``, in kinematic order (the
        model's frame order: each link after its parent)."""
        data = pin.Data(self._model)
        pin.framesForwardKinematics(self._model, data, self._q(q))
        return [
            (f.name, self._T_base_world @ data.oMf[i].homogeneous)
            for i, f in enumerate(self._model.frames)
            if f.type == pin.FrameType.BODY
        ]

    def _frame_id(self, frame: str) -> int:
        if frame not in self.frame_names():
            raise UnknownFrame(
                f"{self._name} has no frame of that name",
                field=("frame",),
                extra={"frames": self.frame_names()},
            )
        return self._model.getFrameId(frame, pin.FrameType.BODY)

    def jacobian(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        """Geometric Jacobian (6, dof) of the tip (or ``frame``) in the base frame, linear rows first."""
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
        options = {
            "max_iterations": int(max_iterations),
            "position_tolerance": float(position_tolerance),
            "orientation_tolerance": float(orientation_tolerance),
            "respect_limits": respect_limits,
        }
        limits = (self._limits[:, 0], self._limits[:, 1], self._revolute)
        if self._task_space == "position_xy":
            if self._closed_form is not None:
                return self._closed_form_result(
                    self._closed_form, T[:2, 3], seed, position_tolerance
                )
            return _ik_numeric.solve_position_xy(
                self._model, self._tip_id, self._T_base_world, T[:2, 3], seed, limits, **options
            )
        goal = self._SE3_world_base * pin.SE3(T[:3, :3], T[:3, 3])
        return _ik_numeric.solve_pose(self._model, self._tip_id, goal, seed, limits, **options)

    def _closed_form_result(
        self, solve: ClosedFormIK, goal_xy: np.ndarray, seed: np.ndarray, tol: float
    ) -> IKResult:
        q, inside = solve(goal_xy, seed)
        err = float(np.linalg.norm(self.fk(q)[:2, 3] - goal_xy))
        return IKResult(q, bool(inside and err <= tol), err, 0.0, 1, bool(inside))

    def __repr__(self) -> str:
        return f"Robot({self._name!r}, dof={self.dof}, task_space={self._task_space!r})"
