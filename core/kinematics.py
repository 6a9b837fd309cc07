"""The small kinematics interface through which core/ talks to a robot.

``robots.model.Robot`` satisfies it; tests may pass a toy model. Conventions:

- ``T_base_tool``: 4x4 homogeneous transform of the tool (tip) frame in the base frame, meters.
- Jacobian: ``(6, dof)`` geometric Jacobian in the base frame, linear rows first (the tip origin's
  linear velocity in [m/s], then the angular velocity in [rad/s], both expressed in the base frame).
- ``task_space``: ``"pose"`` (6+ DOF arms: position and orientation count) or ``"position_xy"``
  (planar arms: only x and y of the tip position count; rows 0 and 1 of the Jacobian).

``Clearance`` is how core sees collisions (``robots.collision.CollisionChecker`` satisfies it): the
distances between a robot's geometry, the obstacles and its own links, and the continuous check
(``PathCheck``) that ``core.collisions`` runs on every answer.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol, runtime_checkable

import numpy as np


class IKResult(NamedTuple):
    """Outcome of one IK solve.

    Attributes:
        positions: Joint positions ``(dof,)`` (the best found, even when not converged).
        success: Residual within tolerance and joint limits respected.
        position_error: Tip position residual in [m] (task components only).
        orientation_error: Orientation residual in [rad] (0 for ``position_xy``).
        iterations: Solver iterations used.
        within_limits: Whether ``positions`` respects the joint position limits.
    """

    positions: np.ndarray
    success: bool
    position_error: float
    orientation_error: float
    iterations: int
    within_limits: bool


class Solutions(Protocol):
    """Every IK solution of one pose (``Kinematics.ik_all``; ``robots.ik.IKSolutions`` is one)."""

    @property
    def positions(self) -> np.ndarray:
        """``(k, dof)`` verified solutions inside the joint limits [rad or m]."""
        ...

    @property
    def configurations(self) -> tuple[str | None, ...]:
        """One configuration label per solution (None for robots without labels)."""
        ...

    @property
    def outside_limits(self) -> int:
        """Distinct solutions (modulo 2 pi) that reproduce the pose only outside the limits."""
        ...


class PathSolutions(Protocol):
    """IK of a sequence of poses on one configuration (``Kinematics.ik_many``; ``robots.ik.IKPath``
    is one)."""

    @property
    def positions(self) -> np.ndarray:
        """``(N, dof)`` joint positions, 2 pi turns unwrapped from the seed; a row without a
        solution repeats the previous one."""
        ...

    @property
    def found(self) -> np.ndarray:
        """``(N,)`` bool: a verified solution with the configuration exists at that pose."""
        ...

    @property
    def within_limits(self) -> np.ndarray:
        """``(N,)`` bool: found, and inside the joint position limits."""
        ...


@dataclass(frozen=True)
class PathSolutionSet:
    """A plain ``PathSolutions`` (the default ``ik_many`` of ``DerivedKinematics``)."""

    positions: np.ndarray
    found: np.ndarray
    within_limits: np.ndarray


@dataclass(frozen=True)
class SolutionSet:
    """A plain ``Solutions`` (the default ``ik_all`` of ``DerivedKinematics``)."""

    positions: np.ndarray
    configurations: tuple[str | None, ...]
    outside_limits: int


class Kinematics(Protocol):
    """What a planner needs to know of a robot."""

    @property
    def name(self) -> str: ...

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    @property
    def dof(self) -> int: ...

    @property
    def task_space(self) -> str: ...

    @property
    def position_limits(self) -> np.ndarray:
        """``(dof, 2)`` lower and upper joint position limits [rad or m]."""
        ...

    @property
    def velocity_limits(self) -> np.ndarray:
        """``(dof,)`` joint speed limits [rad/s or m/s], > 0."""
        ...

    @property
    def acceleration_limits(self) -> np.ndarray:
        """``(dof,)`` joint acceleration limits [rad/s^2 or m/s^2], > 0."""
        ...

    def fk(self, q: np.ndarray) -> np.ndarray:
        """``T_base_tool`` (4, 4) at joint positions ``q`` (dof,)."""
        ...

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        """``T_base_tool`` for each row of ``qs`` (N, dof): shape (N, 4, 4)."""
        ...

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Geometric Jacobian (6, dof) in the base frame, linear rows first."""
        ...

    def jacobian_many(self, qs: np.ndarray) -> np.ndarray:
        """Jacobians ``(N, 6, dof)`` at each row of ``qs`` (N, dof)."""
        ...

    def fk_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(T_base_tool (4, 4), Jacobian (6, dof))`` at ``q`` in one pass."""
        ...

    def fk_jacobian_many(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(T_base_tool (N, 4, 4), Jacobians (N, 6, dof))`` at each row of ``qs`` (N, dof)."""
        ...

    def fk_jacobian_loop(self) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """A function ``q -> fk_jacobian(q)`` for a loop in one thread (a control run), which may
        reuse its scratch space between calls (never share it between threads)."""
        ...

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
        """Joint positions whose tool pose is ``T_base_tool``, starting from (and near) ``seed``.
        ``respect_limits=False`` lets the iterates leave the joint limits (``within_limits`` then
        tells a solution reachable only outside them from no solution)."""
        ...

    @property
    def jerk_limits(self) -> np.ndarray | None:
        """Jerk limits ``(dof,)`` [rad/s^3 or m/s^3], or None where none are known."""
        ...

    @property
    def configuration_labels(self) -> tuple[str, ...]:
        """Every configuration label this robot's IK solutions can carry (empty: no labels)."""
        ...

    def configuration(self, q: np.ndarray) -> str | None:
        """The configuration label (IK branch) of ``q`` (dof,), None for robots without labels."""
        ...

    def configurations(self, qs: np.ndarray) -> list[str | None]:
        """The configuration label of each row of ``qs`` ``(N, dof)``."""
        ...

    def ik_all(self, T_base_tool: np.ndarray, seed: np.ndarray | None = None) -> Solutions:
        """Every IK solution of ``T_base_tool`` inside the limits (nearest ``seed`` first), with
        their labels and the count of solutions only outside the limits; empty when the pose is
        off the workspace. The ``redundant_joints`` are held at the seed's values. Core calls it
        only for robots with labels, and for the goal poses of collision-free motions."""
        ...

    @property
    def redundant_joints(self) -> tuple[str, ...]:
        """Joints ``ik_all`` holds at the seed's values (a 7-joint arm's extra degree of
        freedom); empty when IK has finitely many solutions."""
        ...

    def ik_many(
        self, Ts: np.ndarray, seed: np.ndarray, configuration: str | None = None
    ) -> PathSolutions:
        """IK of every pose of ``Ts`` ``(N, 4, 4)`` on one configuration (default the seed's),
        verified to 1e-9 m and rad (batched for analytic arms)."""
        ...


class SymbolicKinematics(Kinematics, Protocol):
    """A robot whose FK is also a CasADi expression (the bounded-deviation NLP needs it)."""

    def fk_casadi(self) -> Any:
        """``casadi.Function`` ``fk(q) -> (p, R)``: q (dof,) to the tip position p (3,) [m] and
        rotation R (3, 3) in the base frame (typed ``Any``: core/kinematics.py does not import
        CasADi)."""
        ...


DEFAULT_GRAVITY = (0.0, 0.0, -9.81)
"""Gravity [m/s^2] in the robot's base frame when a request gives none."""


class Dynamics(Protocol):
    """Rigid-body inverse dynamics of a robot (``robots.dynamics.RigidBodyDynamics`` is one).

    ``tau = M(q) q'' + C(q, q') q' + g(q)`` [N m or N] per joint, for many samples at once; no
    friction. ``gravity`` is the gravity vector [m/s^2] in the robot's base frame, ``(3,)``.
    """

    def inverse_dynamics(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, gravity: np.ndarray
    ) -> np.ndarray:
        """``tau`` ``(N, dof)`` at the rows of ``q``, ``qd``, ``qdd`` ``(N, dof)``."""
        ...

    def path_coefficients(
        self, q: np.ndarray, dq_ds: np.ndarray, d2q_ds2: np.ndarray, gravity: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(a, b, c)``, each ``(N, dof)``, with ``tau = a s'' + b s'^2 + c`` along a path q(s)
        at the rows of ``q``, ``dq_ds``, ``d2q_ds2`` ``(N, dof)``: ``a = M q_s``, ``b = M q_ss +
        C(q, q_s) q_s``, ``c = g(q)``."""
        ...


TASK_SPACES = ("pose", "position_xy")

SINGULAR_VALUE_THRESHOLD = 1e-3
"""Smallest singular value of the task Jacobian [m/rad for the linear rows] below which a
configuration is singular (the one threshold of every planner: a walk's Type II failure, the
pseudo-inverse step's refusal, the knot methods' singular set and warning). At 1e-3 a joint turning
at 1 rad/s moves the tool by at most 1 mm/s in the weakest direction: following a line there needs
joint rates ~100 times any arm's limits."""


VECTORIZED_JACOBIANS = 10
"""From this many configurations on, ``jacobians`` uses the vectorized ``jacobian_many``; below it one
pinocchio call per row is cheaper (UR5, measured: 12 us a row against 85 us + 0.4 us a row)."""


def jacobians(kin: Kinematics, positions: np.ndarray) -> np.ndarray:
    """Jacobians ``(N, 6, dof)`` at each row of ``positions`` ``(N, dof)``: the robot's vectorized
    ``jacobian_many`` when ``N`` is large enough, else one ``jacobian`` call per row."""
    if len(positions) >= VECTORIZED_JACOBIANS:
        return kin.jacobian_many(np.asarray(positions, dtype=float).reshape(-1, kin.dof))
    return np.stack([kin.jacobian(q) for q in positions])


def task_rows(task_space: str) -> np.ndarray:
    """Indices of the Jacobian rows that the task constrains: all six, or x and y."""
    return np.arange(6) if task_space == "pose" else np.array([0, 1])


class Contact(Protocol):
    """The first configuration of a motion found closer than a pair's threshold."""

    @property
    def time(self) -> float:
        """[s] from the start of the motion."""
        ...

    @property
    def links(self) -> tuple[str, str]:
        """``(robot_link, obstacle_name_or_link)``."""
        ...

    @property
    def distance(self) -> float:
        """[m] signed (negative: penetration)."""
        ...

    @property
    def index(self) -> int:
        """Index (0-based) of the segment between returned points that holds the contact."""
        ...


class PathCheck(Protocol):
    """Result of a continuous check (``Clearance.check_path``)."""

    @property
    def contact(self) -> Contact | None:
        """The first contact, None when the motion is clear."""
        ...

    @property
    def min_clearance(self) -> float:
        """[m] the smallest distance over every checked pair; inf when no pair is checked."""
        ...

    @property
    def closest(self) -> tuple[tuple[str, str], float] | None:
        """``(links, time [s])`` of that smallest distance."""
        ...


@runtime_checkable
class Clearance(Protocol):
    """Distances between a robot's geometry, obstacles and its own links.

    ``pair_names[p]`` is ``(robot_link, obstacle_or_link)``; ``threshold[p]`` [m] is the distance below
    which pair ``p`` is a contact (the clearance for obstacles, 0 for self pairs);
    ``motion_weights`` ``(P, dof)``: pair ``p``'s distance changes by at most
    ``motion_weights[p] @ |dq|`` [m] over a linear joint step ``dq`` (a Lipschitz bound; a row of
    zeros: a robot link fixed to the base, whose distance no joint changes).
    """

    @property
    def pair_names(self) -> list[tuple[str, str]]: ...

    @property
    def threshold(self) -> np.ndarray: ...

    @property
    def motion_weights(self) -> np.ndarray: ...

    def distances(self, qs: np.ndarray) -> np.ndarray:
        """Signed distances ``(N, P)`` [m] of every pair for each row of ``qs`` ``(N, dof)``."""
        ...

    def check_path(self, times: np.ndarray, qs: np.ndarray) -> PathCheck:
        """Continuous check of the motion through ``qs`` ``(N, dof)`` at ``times`` ``(N,)`` [s], joints
        moving linearly between rows: first contact, min clearance and closest pair."""
        ...

    def close_pairs(
        self, q: np.ndarray, d_influence: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Pairs closer than ``d_influence`` [m] at ``q``: indices ``(m,)``, distances ``(m,)`` [m],
        unit normals ``(m, 3)`` towards the robot point, point Jacobians ``(m, 3, dof)``: the inputs
        of ``core.clearance.velocity_damper_rows``."""
        ...
