"""Damped least-squares joint rates as a QP: build it, solve it, and the per-tick OSQP path.

One control tick of ``resolved_rate_dls`` asks for the joint rates ``qd`` (dof,) that best produce the
task twist ``V`` (the rows of the Jacobian ``J`` that the task constrains) while staying inside the
joint velocity limits, changing by at most the acceleration limits over the tick ``dt`` and keeping
every joint able to stop before its position limits (``rate_bounds``)::

    minimize    ||J qd - V||^2 + lambda^2 ||qd||^2
    subject to  max(-v_max, qd_prev - a_max dt, brake_lo(q)) <= qd
                qd <= min(v_max, qd_prev + a_max dt, brake_hi(q))

``brake_hi(q) = -b dt + sqrt((b dt)^2 + 2 b g)``, ``g = q_max - margin - q``, is the largest rate
from which the joint, moving ``qd dt`` this tick and then braking at ``b = BRAKING_SHARE a_max``,
stops by ``q_max - margin`` (``qd dt + qd^2 / (2 b) <= g``; ``brake_lo`` likewise). As in Drake's
DifferentialInverseKinematics and Pink, the previous tick's rates +- ``a_max dt`` box the rates,
so a joint reaching its limit cannot make the others jump. Braking at ``b`` from a rate that met
the bound meets the next tick's bound, so the box is never empty. Without acceleration limits
(``RateLimits.acceleration`` None) the position bound is the round-2 one, ``(q_min - q)/dt <= qd
<= (q_max - q)/dt``.

In the standard form ``1/2 x^T P x + c^T x`` of OSQP and qpsolvers, ``P = J^T J + lambda^2 I`` and
``c = -J^T V`` (the objective halved; same minimizer). With ``lambda = 0`` and no active bound the
minimizer is the pseudo-inverse step ``J^+ V`` (for ``J`` of full column rank).

``build_dls_qp`` returns a ``qpsolvers.Problem`` to inspect or hand to any installed solver with
``solve_dls_qp``. ``core.cartesian.rate.tick_qp.DlsQpSolver`` is the per-tick path: one OSQP workspace per request whose ``P``,
``c`` and bounds are updated in place each tick and warm-started (qpsolvers sets up a new OSQP
workspace on every call).

OSQP settings, measured by ``bench/rate_tick.py`` on UR5 and Panda ticks with one joint 1 urad from
its limit (``bench/RESULTS.md``):

- At ``dt = 1 ms`` that joint's bound ``(q_max - q)/dt`` is 1e-3 rad/s, the size of OSQP's default
  tolerance: with ``eps = 1e-3`` OSQP's answer lies up to 1.2e-3 rad/s (123 % of the bound) outside
  it, and on the Panda, whose QP is ill-conditioned, default settings miss the exact rates by
  2 rad/s. At ``eps_abs = eps_rel = 1e-9`` they match to 3e-9 rad/s, for 24-34 iterations instead
  of 11-13 at 1e-6: about 5 us more per tick.
- OSQP checks termination every 25 iterations by default, which hides what a warm start saves (no
  solve stops before iteration 25); checking every iteration, a warm start takes 24 iterations
  against 38 cold on the UR5, and 34 against more than 200 on the Panda. rho adapts every 25.
- OSQP 1.x's polishing prints to stdout whenever no bound is active (most ticks), so it is off; the
  returned rates are clipped into the bounds, which makes them respect the limits exactly.
- A solve that stops short (``max_iter`` = 200, or solved inaccurately) is replaced by the exact
  bounded least squares (``bounded_least_squares``, scipy's BVLS), and OSQP is warm-started from
  it: ADMM is slow on the Panda's QP with a joint against its limit (measured: 1000 iterations did
  not reach 1e-9 on the first ticks of such a run), an active-set method is not.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import qpsolvers
import scipy.sparse as sp
from scipy.optimize import lsq_linear

from core.errors import InputError, NoConvergence
from core.kinematics import Kinematics

BRAKING_SHARE = 0.2
"""Share of a joint's acceleration limit its braking bound brakes at. A joint that must stop at a
limit hands its part of the twist to the others, whose rates may change by no more than their own
limits allow: braking at the full limit made the others lag (measured: the Panda turning its flange
0.5 rad with joint 7 0.3 rad from its limit left the line by 5.4 mm, joints 1 and 3 at their
acceleration limits); at 0.5 by 0.97 mm, at 0.2 by 8 um (joints up to 0.85 of their limits)."""
SINGULAR_REGION = 0.05
"""epsilon: damping starts when the smallest singular value of the task Jacobian falls below it."""
MAX_DAMPING = 0.05
"""lambda_max: the damping reached at an exact singularity."""
REDUNDANCY_DAMPING = 3e-3
"""Least damping for a redundant arm (more joints than task rows). With lambda = 0 its QP is not
strictly convex: the rates are unique only up to self-motion, which OSQP leaves where the warm
start puts it (measured on the Panda: up to 5e-3 rad/s from the minimum-norm step, and self-motion
that persists from tick to tick). This floor makes the step the minimum-norm one (1e-8 rad/s) at a
relative task error of at most (lambda / sigma_min)^2, 0.4 % at the edge of the singular region,
which the feedback term removes."""

OSQP_SETTINGS: dict[str, float | int | bool] = {
    "eps_abs": 1e-9,
    "eps_rel": 1e-9,
    "check_termination": 1,
    "adaptive_rho_interval": 25,
    "polishing": False,
    "warm_starting": True,
    "max_iter": 200,
    "verbose": False,
}
"""Settings of the per-tick OSQP workspace (and defaults for ``solve_dls_qp(..., "osqp")``)."""
ONE_SHOT_OSQP_SETTINGS: dict[str, float | int | bool] = {
    "eps_abs": 1e-10,
    "eps_rel": 1e-10,
    "max_iter": 4000,
}
"""For ``solve_dls_qp`` (no fallback there): a cold start stops ~10x farther from the optimum than a
warm-started tick at the same tolerance (measured: 1.2e-6 against 1.3e-7 rad/s on UR5 problems)."""


def damping(
    sigma_min: float,
    region: float = SINGULAR_REGION,
    max_damping: float = MAX_DAMPING,
    floor: float = 0.0,
) -> float:
    """Damping lambda for the smallest singular value ``sigma_min`` of the task Jacobian.

    ``lambda^2 = (1 - (sigma_min / region)^2) * max_damping^2`` inside the singular region
    (``sigma_min < region``), else 0: zero away from singularities, so the step there is the exact
    pseudo-inverse, and growing smoothly (C1 in sigma) to ``max_damping`` at a singularity. The form
    is Chiaverini's (IEEE Trans. Robot. Autom. 13(3), 1997, eq. 14), after the damped least-squares
    inverse of Nakamura & Hanafusa (1986) and Wampler (1986) and the singular-value-based damping of
    Maciejewski & Klein (1988). ``floor`` is a least value (``REDUNDANCY_DAMPING`` for redundant arms).
    """
    if sigma_min >= region:
        return floor
    return max(floor, max_damping * float(np.sqrt(1.0 - (sigma_min / region) ** 2)))


class RateLimits(NamedTuple):
    """Joint limits that bound the rates of one tick.

    Attributes:
        position: ``(dof, 2)`` lower and upper joint positions [rad or m].
        velocity: ``(dof,)`` joint speed limits [rad/s or m/s], > 0.
        acceleration: ``(dof,)`` joint acceleration limits [rad/s^2 or m/s^2], > 0, or None.
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray | None = None

    @classmethod
    def of(cls, robot: Kinematics) -> RateLimits:
        """The position, velocity and acceleration limits of ``robot``."""
        return cls(
            np.asarray(robot.position_limits, dtype=float),
            np.asarray(robot.velocity_limits, dtype=float),
            np.asarray(robot.acceleration_limits, dtype=float),
        )


@dataclass(frozen=True)
class QpStep:
    """Joint rates of one tick.

    Attributes:
        x: Joint rates ``(dof,)`` [rad/s], inside the bounds exactly (clipped after the solve).
        found: The solver reported a solution (OSQP: solved, or solved inaccurately).
        iterations: Solver iterations (ADMM iterations for OSQP; 0 when the backend does not say).
        solve_time: Wall time [s] of the update and solve.
        status: The solver's status.
        violation: How far the solver's own rates were outside the bounds before clipping [rad/s].
        fallback: OSQP stopped short and the exact bounded least squares gave the rates.
    """

    x: np.ndarray
    found: bool
    iterations: int
    solve_time: float
    status: str
    violation: float = 0.0
    fallback: bool = False


def braking_bounds(
    q: np.ndarray, limits: RateLimits, dt: float, margin: np.ndarray | float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """``(brake_lo, brake_hi)`` (dof,) [rad/s]: the rates from which each joint, after moving
    ``qd dt`` this tick, still stops by braking at ``BRAKING_SHARE`` of its acceleration limit
    within ``[q_min + margin, q_max - margin]`` (see the module docstring;
    ``limits.acceleration`` must be set). 0 for a joint already beyond that range on the side it
    would move to."""
    if limits.acceleration is None:
        raise ValueError("braking_bounds needs acceleration limits")
    a = BRAKING_SHARE * limits.acceleration
    adt = a * dt
    room_hi = np.maximum(limits.position[:, 1] - margin - q, 0.0)
    room_lo = np.maximum(q - (limits.position[:, 0] + margin), 0.0)
    upper = np.sqrt(adt * adt + 2.0 * a * room_hi) - adt
    lower = adt - np.sqrt(adt * adt + 2.0 * a * room_lo)
    return lower, upper


def rate_bounds(
    q: np.ndarray,
    limits: RateLimits,
    dt: float,
    previous: np.ndarray | None = None,
    margin: np.ndarray | float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``(lower, upper)`` (dof,) [rad/s] on the rates of a tick of ``dt`` [s] from ``q``.

    The velocity limits intersected with the position bound (the braking bound of
    ``braking_bounds`` when ``limits.acceleration`` is set, else ``(q_min - q)/dt <= qd <= (q_max
    - q)/dt``) and, given the ``previous`` tick's rates, ``previous +- a_max dt``. Were ``q``
    outside its limits (the controller never lets it), the bounds would move it back at full speed
    rather than becoming empty; were they empty by rounding, the upper bound wins.
    """
    v = limits.velocity
    if limits.acceleration is None:
        lower = np.maximum(-v, (limits.position[:, 0] - q) / dt)
        upper = np.minimum(v, (limits.position[:, 1] - q) / dt)
        return np.minimum(lower, v), np.maximum(upper, -v)
    brake_lo, brake_hi = braking_bounds(q, limits, dt, margin)
    lower, upper = np.maximum(-v, brake_lo), np.minimum(v, brake_hi)
    if previous is not None:
        step = limits.acceleration * dt
        lower = np.maximum(lower, previous - step)
        upper = np.minimum(upper, previous + step)
    return np.minimum(lower, upper), upper


def build_dls_qp(
    J: np.ndarray,
    V: np.ndarray,
    lam: float,
    q: np.ndarray,
    limits: RateLimits,
    dt: float,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> qpsolvers.Problem:
    """The QP of one tick (see the module docstring) as a ``qpsolvers.Problem`` with box bounds.

    Args:
        J: Task rows of the Jacobian, ``(m, dof)`` (m = 6 for ``pose``, 2 for ``position_xy``).
        V: Task twist ``(m,)`` [m/s, rad/s], base frame, linear part first.
        lam: Damping lambda >= 0 (units of the singular values of ``J``).
        q: Joint positions ``(dof,)`` at the start of the tick [rad or m].
        limits: Joint position and velocity limits.
        dt: Control period [s], > 0.
        bounds: The tick's rate bounds ``(lower, upper)`` when known (the controller's, with the
            previous rates), else ``rate_bounds(q, limits, dt)``.
    """
    lower, upper = rate_bounds(q, limits, dt) if bounds is None else bounds
    P = J.T @ J + lam**2 * np.eye(J.shape[1])
    return qpsolvers.Problem(P, -J.T @ V, lb=lower, ub=upper)


def check_solver(solver: str) -> str:
    """``solver`` if qpsolvers has it installed, else ``InputError`` on ``solver`` listing them."""
    if solver not in qpsolvers.available_solvers:
        available = sorted(qpsolvers.available_solvers)
        raise InputError(
            f"solver must be one of the installed QP solvers: {', '.join(available)}",
            field=("solver",),
            extra={"available": available},
        )
    return solver


def solve_dls_qp(problem: qpsolvers.Problem, solver: str = "osqp", **options: Any) -> QpStep:
    """Solve ``problem`` (from ``build_dls_qp``) with any installed qpsolvers backend.

    ``options`` go to the backend; for ``osqp`` they default to ``OSQP_SETTINGS`` with
    ``ONE_SHOT_OSQP_SETTINGS``. The rates are
    clipped into the problem's bounds. Raises ``NoConvergence`` when the backend finds no solution.
    """
    check_solver(solver)
    if solver == "osqp":
        options = {**OSQP_SETTINGS, **ONE_SHOT_OSQP_SETTINGS, "raise_error": False, **options}
        options.pop("warm_starting", None)
        P, q, G, h, A, b, lb, ub = problem.unpack()  # OSQP wants CSC (qpsolvers would warn)
        problem = qpsolvers.Problem(sp.csc_matrix(P), q, G, h, A, b, lb, ub)
    start = time.perf_counter()
    try:
        solution = qpsolvers.solve_problem(problem, solver=solver, **options)
    except Exception as e:  # every backend raises its own exception types
        raise NoConvergence(f"QP solver {solver} failed on the joint-rate problem") from e
    elapsed = time.perf_counter() - start
    if solution.x is None or not np.all(np.isfinite(solution.x)):
        raise NoConvergence(f"QP solver {solver} found no joint rates")
    info = (solution.extras or {}).get("info")
    x = np.clip(solution.x, problem.lb, problem.ub)
    return QpStep(
        x=x,
        found=bool(solution.found),
        iterations=int(getattr(info, "iter", 0) or 0),
        solve_time=elapsed,
        status=str(getattr(info, "status", "solved" if solution.found else "not solved")),
        violation=float(np.abs(solution.x - x).max()),
    )


def bounded_least_squares(
    J: np.ndarray, V: np.ndarray, lam: float, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """The exact minimizer of ``||J qd - V||^2 + lam^2 ||qd||^2`` within the bounds ``(dof,)``:
    ``min ||A qd - b||^2`` with ``A = [J; lam I]``, ``b = [V; 0]`` by scipy's BVLS (an active-set
    method, Stark & Parker 1995). About 90 us for 7 joints: the fallback of ``DlsQpSolver``."""
    dof = J.shape[1]
    A = np.vstack([J, lam * np.eye(dof)])
    b = np.concatenate([V, np.zeros(dof)])
    upper_open = np.maximum(upper, lower + 1e-12)  # BVLS wants lower < upper strictly
    x = lsq_linear(A, b, bounds=(lower, upper_open), method="bvls", tol=1e-12).x
    return np.minimum(np.maximum(x, lower), upper)
