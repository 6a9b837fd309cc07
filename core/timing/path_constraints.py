"""The limits a path timing law keeps, as rows affine in (s'', s'^2) at any path parameter.

Along a joint path q(s), with u = s'' and x = s'^2, the joint velocity is q_s s', the acceleration
q_s u + q_ss x, and (with dynamics) the torque a u + b x + c (``Dynamics.path_coefficients``). Every
limit is therefore a row ``|A u + B x + C| <= h`` at a fixed s:

====================== =============== ================= ======= =====================
limit                   A               B                 C       h
====================== =============== ================= ======= =====================
joint velocity          0               q_s^2             0       v^2
joint acceleration      q_s             q_ss              0       a
tool linear speed       0               |J_v q_s|^2       0       v_tool^2
tool angular speed      0               |J_w q_s|^2       0       w_tool^2
tool linear accel.      rho_v           d rho_v / ds      0       a_tool
tool angular accel.     rho_w           d rho_w / ds      0       alpha_tool
joint effort            M q_s           M q_ss + C q_s    g       tau
====================== =============== ================= ======= =====================

``PathLimits.rows`` evaluates A, B, C at many samples of the path at once; rows whose limit is
infinite are left out. Velocities are squared so that every row is affine in x; a row's value over
its bound (``ratio``) is then the square of the velocity's. The tool's rates per unit path speed
(|J_v q_s|, |J_w q_s|) come from a callable the caller builds from its kinematics
(``tool_rates``), so this module needs no robot. A tool acceleration limit bounds the rate of
change of the tool's speed, d|v|/dt = rho s'' + (d rho / ds) s'^2 with rho = |J_v q_s| (the
acceleration along a line or arc; the centripetal part of a curve is left to the joint limits), from
``core.timing.tool_path.tool_accelerations``.

Limits that change along the path (a motion program's segments, each with its own scales and tool
limits) are ``local``: a factor of every row's bound at any s; ``rows`` then needs the samples'
path parameters (``PathSamples.s``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from core.kinematics import Dynamics, Kinematics, jacobians

ToolRates = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""``(q (K, dof), dq/ds (K, dof)) -> (K, 2)``: the tool's linear [m] and angular [rad] speed per
unit of path speed (|J_v q_s| and |J_w q_s|, Jacobian in the base frame)."""


def tool_rates(kin: Kinematics) -> ToolRates:
    """The ``ToolRates`` of a robot: its tip Jacobian (linear rows first) times dq/ds."""

    def rates(q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        J = jacobians(kin, q)
        v = np.einsum("kij,kj->ki", J, dq)
        return np.column_stack([np.linalg.norm(v[:, :3], axis=1), np.linalg.norm(v[:, 3:], axis=1)])

    return rates


@dataclass(frozen=True)
class ToolSpeed:
    """Tool speed limits: ``max_linear`` [m/s], ``max_angular`` [rad/s] (None: no limit)."""

    rates: ToolRates
    max_linear: float | None = None
    max_angular: float | None = None


ToolAccelerationRates = Callable[
    [np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]
]
"""``(q, dq/ds, d2q/ds2 (K, dof)) -> (rho, rho_s)``, each ``(K, 2)``: the tool's linear [m] and
angular [rad] speed per unit path speed and their derivatives along s."""

LocalBounds = Callable[[np.ndarray], np.ndarray]
"""``s (K,) -> (K, n)``: a factor of the bound of every row (all ``n`` rows in ``labels`` order,
dropped ones included) at each path parameter: 1 keeps it, inf lifts it there (velocity and speed
rows are squared: their factors too)."""


@dataclass(frozen=True)
class ToolAcceleration:
    """Limits [m/s^2], [rad/s^2] of the rate of change of the tool's speed and angular speed (None:
    no limit), with the tool's ``rates`` along the path."""

    rates: ToolAccelerationRates
    max_linear: float | None = None
    max_angular: float | None = None


@dataclass(frozen=True)
class Effort:
    """Effort limits ``limits`` ``(dof,)`` [N m or N] under ``dynamics``, with ``gravity`` ``(3,)``
    [m/s^2] in the base frame."""

    dynamics: Dynamics
    limits: np.ndarray
    gravity: np.ndarray


@dataclass(frozen=True)
class Rows:
    """Row coefficients at K samples: ``A``, ``B``, ``C`` ``(K, m)`` with ``|A u + B x + C| <= h``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray


KINDS = (
    "velocity",
    "acceleration",
    "linear_speed",
    "angular_speed",
    "linear_acceleration",
    "angular_acceleration",
    "effort",
)
"""Names of the limits, as ``binding`` reports them."""


@dataclass(frozen=True)
class PathLimits:
    """Everything a path timing law keeps.

    Attributes:
        velocity: Joint speed limits ``(dof,)`` [rad/s or m/s] (``inf``: none).
        acceleration: Joint acceleration limits ``(dof,)`` [rad/s^2 or m/s^2] (``inf``: none).
        tool: Tool speed limits, or None.
        effort: Effort limits with the robot's dynamics, or None.
        tool_acceleration: Tool acceleration limits, or None.
        local: Factors of the bounds along the path (``LocalBounds``), or None: the same
            everywhere.
    """

    velocity: np.ndarray
    acceleration: np.ndarray
    tool: ToolSpeed | None = None
    effort: Effort | None = None
    tool_acceleration: ToolAcceleration | None = None
    local: LocalBounds | None = None
    _keep: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_keep", np.isfinite(self._all_bounds()))

    def _all_bounds(self) -> np.ndarray:
        v = np.asarray(self.velocity, dtype=float)
        a = np.asarray(self.acceleration, dtype=float)
        tool = [np.inf, np.inf]
        if self.tool is not None:
            tool = [
                np.inf if x is None else float(x) ** 2
                for x in (self.tool.max_linear, self.tool.max_angular)
            ]
        acc = [np.inf, np.inf]
        if self.tool_acceleration is not None:
            acc = [
                np.inf if x is None else float(x)
                for x in (self.tool_acceleration.max_linear, self.tool_acceleration.max_angular)
            ]
        tau = np.full(0, np.inf) if self.effort is None else np.asarray(self.effort.limits, float)
        return np.concatenate([v**2, a, tool, acc, tau])

    @property
    def bounds(self) -> np.ndarray:
        """``h`` of every kept row ``(m,)``."""
        return self._all_bounds()[self._keep]

    def labels(self) -> list[tuple[str, int | None]]:
        """``(kind, joint index or None)`` of every kept row, in row order."""
        dof = len(self.velocity)
        every: list[tuple[str, int | None]] = [("velocity", j) for j in range(dof)]
        every += [("acceleration", j) for j in range(dof)]
        every += [("linear_speed", None), ("angular_speed", None)]
        every += [("linear_acceleration", None), ("angular_acceleration", None)]
        if self.effort is not None:
            every += [("effort", j) for j in range(dof)]
        return [lab for lab, keep in zip(every, self._keep, strict=True) if keep]

    def rows(
        self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, s: np.ndarray | None = None
    ) -> Rows:
        """A, B, C of every kept row at the samples ``q``, ``dq`` = dq/ds, ``ddq`` = d2q/ds2
        ``(K, dof)`` at path parameters ``s`` ``(K,)`` (needed with ``local`` bounds; every
        ``PathSamples`` carries them)."""
        k, dof = dq.shape
        zero, pair = np.zeros((k, dof)), np.zeros((k, 2))
        A = [zero, dq]
        B = [dq * dq, ddq]
        C = [zero, zero]
        if self.tool is not None and (self._keep[2 * dof] or self._keep[2 * dof + 1]):
            rates = np.asarray(self.tool.rates(q, dq), dtype=float)
        else:
            rates = pair
        A.append(pair)
        B.append(rates * rates)
        C.append(pair)
        rho, rho_s = pair, pair
        if self.tool_acceleration is not None and self._keep[2 * dof + 2 : 2 * dof + 4].any():
            rho, rho_s = self.tool_acceleration.rates(q, dq, ddq)
        A.append(np.asarray(rho, dtype=float))
        B.append(np.asarray(rho_s, dtype=float))
        C.append(pair)
        if self.effort is not None:
            e = self.effort
            a, b, c = e.dynamics.path_coefficients(q, dq, ddq, e.gravity)
            A.append(a)
            B.append(b)
            C.append(c)
        keep = self._keep
        out = [np.concatenate(x, axis=1) for x in (A, B, C)]
        if self.local is not None:
            if s is None:
                raise ValueError("limits that vary along the path need the samples' s")
            factor = np.asarray(self.local(np.asarray(s, dtype=float)), dtype=float)
            with np.errstate(divide="ignore"):
                inverse = np.where(np.isfinite(factor), 1.0 / factor, 0.0)
            out = [x * inverse for x in out]
        return Rows(*(x[:, keep] for x in out))


def row_names(limits: PathLimits, joint_names: Sequence[str]) -> list[str]:
    """Human names of the kept rows (``"acceleration of j2"``, ``"linear_speed"``)."""
    return [
        kind if joint is None else f"{kind} of {joint_names[joint]}"
        for kind, joint in limits.labels()
    ]
