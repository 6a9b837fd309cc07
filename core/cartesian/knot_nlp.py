"""Bounded deviation as constraints: knot configurations are the decision variables of an NLP.

The returned joint path is the same kind as Taylor's (``core.cartesian.knot_path.KnotPath``: the C2 cubic
spline q(s) through K knots at path parameters s_k, not-a-knot, timed along s), so the deviation of
the path actually returned is constrained at check points sigma_j (``checks`` inside every knot
segment, and the interior knots):

- decision variables: the K-2 interior knots (the first is ``q_start``, the last the goal's
  configuration, both fixed) and the spline's second derivatives at the K knots, tied to the knots
  by the spline's linear conditions (``spline_equations``: C1 at the knots, not-a-knot ends). The
  spline at a check is then a fixed combination of its segment's 2 knots and 2 second derivatives
  (``check_weights``), so each constraint touches few variables;
- joint limits: bounds on the knots, linear constraints on the spline at every check;
- deviation (``deviation_constraints``, each scaled to <= 1): position and orientation at the closest
  line point that ``StraightLine.deviation`` uses (s*, the position and orientation projections
  weighed by the tolerances; the orientation projection written smoothly as
  2 atan2(u . vee(E - E^T), 1 + tr E) for E = R0^T R and the line's axis u), and the orientation
  also at the closest point by position alone, so the bound holds whichever of the two ways a
  client measures it. The closest point is free, not the knot's nominal s: a knot need not lie on
  the line, nor at its own s, only within the bound, which is why fewer knots do. Bounds:
  |p - p_line(s*)|^2 <= (MARGIN tol_p)^2, 3 - tr(R_line^T R) <= 2 (1 - cos(MARGIN tol_o));
  orientation ignored for ``position_xy`` arms;
- cost: smoothness, the squared second differences of the knots (``cost="length"``: the squared
  knot steps, a joint path length).

FK is a CasADi expression built from the pinocchio model (``robots.symbolic.fk_casadi``; a robot may
also bring its own ``fk_casadi()``). IPOPT gets the constraint Jacobian and the Lagrangian's Hessian
assembled from each check's small SX derivatives (``derivatives``; equal to CasADi's own, several
times faster). Each solve keeps every knot joint within ``TRUST_BOX`` of its warm start (the
constraints are steep: 1 mm is a few mrad) and has IPOPT iteration and wall-time caps.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import casadi as ca
import numpy as np
from scipy import sparse

from core.cartesian.knot_nlp_derivatives import derivatives
from core.cartesian.knot_path import KnotPath, Knots
from core.cartesian.knots import MARGIN
from core.cartesian.measure import dense_times
from core.clearance import stacked_rows
from core.geometry import so3
from core.kinematics import Kinematics
from core.path.arc import Arc
from core.path.line import StraightLine

NLP_CHECKS = 8
"""Interior check points per knot segment in the NLP's constraints."""
NLP_MAX_ITER = 100
"""IPOPT iteration cap per solve."""
NLP_MAX_WALL_TIME = 10.0
"""[s] IPOPT wall-time cap per solve (further capped by the task's deadline)."""
NLP_TOTAL_WALL_TIME = 30.0
"""[s] wall time for the whole knot-count search."""
ACCEPT = 0.5 * (1.0 + MARGIN)
"""A solution is accepted when the spline stays within this share of the tolerances at
``PATH_CHECKS`` points per knot segment (the NLP aims at ``MARGIN`` at its own checks)."""
TRUST_BOX = 0.03
"""[rad or m] each knot joint stays within this of its warm start during a solve."""
COSTS = ("smoothness", "length")
IPOPT_OPTIONS: dict[str, Any] = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "ipopt.mu_init": 1e-3,
    "ipopt.mu_strategy": "adaptive",
}
"""IPOPT settings: quiet; a small initial barrier parameter keeps the first steps near the (often
feasible) warm start, which the steep deviation constraints need."""
SYMBOLIC_LOCK = threading.Lock()
"""Held while CasADi expressions are built: symbolic construction shares reference-counted nodes
(constants, the cached FK) that are not safe to touch from two threads at once. Solving is not
serialized: each request evaluates its own solver."""
SUCCESS_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
TIME_STATUSES = ("Maximum_WallTime_Exceeded", "Maximum_CpuTime_Exceeded")
ITERATION_CAP = ("Maximum_Iterations_Exceeded",)


def _clip01(x: ca.SX) -> ca.SX:
    return ca.fmin(ca.fmax(x, 0.0), 1.0)


def deviation_constraints(
    line: StraightLine | Arc,
    p: ca.SX,
    R: ca.SX,
    tol_p: float,
    tol_o: float,
    margin: float = MARGIN,
) -> list[ca.SX]:
    """Scaled deviation constraints (each <= 1) of one tool pose (p (3,), R (3, 3)) from ``line``
    (an ``Arc``: ``arc_constraints``).

    Position and orientation at the closest line point of ``StraightLine.deviation`` (s*: the
    position and orientation projections weighed by ``tol_p`` [m] and ``tol_o`` [rad]), and the
    orientation also at the closest point by position alone (s_p, where the position deviation is
    the plain distance to the segment), so the bound holds for either way of measuring it. The
    bounds are ``margin`` times the tolerances. ``position_xy``: the position constraint only.
    """
    if isinstance(line, Arc):
        return arc_constraints(line, p, R, tol_p, tol_o, margin)
    rows = 2 if line.task_space == "position_xy" else 3
    d = line.delta_p[:rows]
    length_sq = float(d @ d)
    pt = p[:rows]
    s_pos = ca.dot(pt - line.p0[:rows], d) / length_sq if length_sq > 1e-12 else ca.SX(0.0)
    w_pos = length_sq / tol_p**2
    theta = line.angle
    E = ca.DM(line.R0.T) @ R  # the pose's rotation relative to the line's start
    if line.task_space == "pose" and theta > 1e-12:
        u = line.rotvec / theta
        vee = ca.vertcat(E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1])
        s_rot = 2.0 * ca.atan2(ca.dot(ca.DM(u), vee), 1.0 + ca.trace(E)) / theta
        w_rot = theta**2 / tol_o**2
    else:
        s_rot, w_rot = ca.SX(0.0), 0.0
    if w_pos + w_rot > 0.0:
        s = _clip01((w_pos * s_pos + w_rot * s_rot) / (w_pos + w_rot))
    else:
        s = ca.SX(0.0)
    err = pt - (line.p0[:rows] + s * d)
    out = [ca.dot(err, err) / (margin * tol_p) ** 2]
    if line.task_space == "pose":
        K = so3.skew(line.rotvec / theta) if theta > 1e-12 else np.zeros((3, 3))
        scale = 2.0 * (1.0 - np.cos(margin * tol_o))

        def misalignment(at: ca.SX) -> ca.SX:
            # 3 - tr(R_line(at)^T R) = 2 (1 - cos angle), R_line(at) = R0 exp(at * rotvec)
            E_line = ca.DM.eye(3) + ca.sin(at * theta) * K + (1.0 - ca.cos(at * theta)) * (K @ K)
            return (3.0 - ca.trace(E_line.T @ E)) / scale

        out.append(misalignment(s))
        if length_sq > 1e-12:
            out.append(misalignment(_clip01(s_pos)))
    return out


def arc_constraints(
    arc: Arc, p: ca.SX, R: ca.SX, tol_p: float, tol_o: float, margin: float = MARGIN
) -> list[ca.SX]:
    """``deviation_constraints`` for an arc, at its closest point of ``Arc.deviation`` (s* by the
    angle about the centre, measured from the arc's middle so it is smooth over the whole arc,
    clipped to [0, 1]): distance to the arc point and (``pose``) misalignment with the slerp there."""
    theta = arc.theta
    mid = np.cos(0.5 * theta) * arc.u + np.sin(0.5 * theta) * arc.v
    d = p - ca.DM(arc.center)
    psi = ca.atan2(ca.dot(d, ca.DM(np.cross(arc.normal, mid))), ca.dot(d, ca.DM(mid)))
    s = _clip01(0.5 + psi / theta)
    radius = arc.r0 + s * (arc.r1 - arc.r0)
    on_arc = ca.DM(arc.center) + radius * (
        ca.cos(s * theta) * ca.DM(arc.u) + ca.sin(s * theta) * ca.DM(arc.v)
    )
    err = p - on_arc
    out = [ca.dot(err, err) / (margin * tol_p) ** 2]
    angle = arc.angle
    if arc.task_space == "pose":
        K = so3.skew(arc.rotvec / angle) if angle > 1e-12 else np.zeros((3, 3))
        E = ca.DM(arc.R0.T) @ R
        E_arc = ca.DM.eye(3) + ca.sin(s * angle) * K + (1.0 - ca.cos(s * angle)) * (K @ K)
        out.append((3.0 - ca.trace(E_arc.T @ E)) / (2.0 * (1.0 - np.cos(margin * tol_o))))
    return out


@dataclass(frozen=True)
class KnotNLP:
    """The NLP for K knots at fixed path parameters, built once, solved from any start.

    Decision vector ``x``: the interior knots (``dof * (K-2)``, knot after knot), then the spline's
    second derivatives d2q/ds2 at every knot (``dof * K``), tied to the knots by the spline's linear
    conditions (``spline_equations``). The spline at a check point then depends on the 2 knots and 2
    second derivatives of its segment only, so derivatives stay sparse and cheap.

    Attributes:
        solver: CasADi ``nlpsol`` (IPOPT).
        s: Knot path parameters ``(K,)``.
        first, last: Fixed end knots ``(dof,)``.
        lbx, ubx: Bounds on ``x`` (joint limits on the knots).
        lbg, ubg: Constraint bounds: deviation <= 1, spline conditions = 0, joint limits at checks.
        checks: Path parameters of the check points ``(M,)``.
    """

    solver: ca.Function
    s: np.ndarray
    first: np.ndarray
    last: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    checks: np.ndarray

    @property
    def n_knot_variables(self) -> int:
        return (len(self.s) - 2) * len(self.first)

    def x_of(self, positions: np.ndarray) -> np.ndarray:
        """Decision vector of knot positions ``(K, dof)`` (end rows replaced by the fixed ends)."""
        q = np.vstack([self.first, np.asarray(positions, dtype=float)[1:-1], self.last])
        moments = KnotPath(Knots(self.s, q))(self.s, 2)
        return np.concatenate([q[1:-1].ravel(), moments.ravel()])

    def positions_of(self, x: np.ndarray) -> np.ndarray:
        """Knot positions ``(K, dof)`` of a decision vector."""
        x = np.asarray(x, dtype=float)[: self.n_knot_variables]
        return np.vstack([self.first, x.reshape(len(self.s) - 2, len(self.first)), self.last])


def deviation_function(
    fk: ca.Function,
    line: StraightLine | Arc,
    position_tolerance: float,
    orientation_tolerance: float,
) -> ca.Function:
    """``g(q)``: the scaled deviation constraints (each <= 1) of configuration ``q`` (dof,).

    One SX function per plan (FK inlined), mapped over the check points of every knot count.
    """
    q = ca.SX.sym("q", fk.size1_in(0))
    p, R = fk(q)
    g = deviation_constraints(line, p, R, position_tolerance, orientation_tolerance)
    return ca.Function("deviation", [q], [ca.vertcat(*g)], ["q"], ["g"])


def spline_equations(s_knots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(E, F)`` (K, K) with ``E @ M = F @ Q`` the conditions on the second derivatives ``M``
    (K,) of the not-a-knot cubic spline through values ``Q`` (K,) at ``s_knots`` (K >= 3):
    C1 at the interior knots, a continuous third derivative at the second and the second-to-last
    knot (a parabola, constant M, for 3 knots). Those are ``scipy``'s ``CubicSpline`` conditions."""
    k = len(s_knots)
    h = np.diff(s_knots)
    E, F = np.zeros((k, k)), np.zeros((k, k))
    for i in range(1, k - 1):
        E[i, i - 1 : i + 2] = h[i - 1], 2.0 * (h[i - 1] + h[i]), h[i]
        F[i, i - 1 : i + 2] = 6.0 / h[i - 1], -6.0 / h[i - 1] - 6.0 / h[i], 6.0 / h[i]
    if k == 3:
        E[0, :2], E[2, 1:] = (1.0, -1.0), (1.0, -1.0)
    else:
        E[0, :3] = -1.0 / h[0], 1.0 / h[0] + 1.0 / h[1], -1.0 / h[1]
        E[-1, -3:] = -1.0 / h[-2], 1.0 / h[-2] + 1.0 / h[-1], -1.0 / h[-1]
    return E, F


def check_weights(
    s_knots: np.ndarray, sigma: np.ndarray
) -> tuple[sparse.csr_matrix, sparse.csr_matrix]:
    """``(A, B)`` (M, K), two nonzeros a row: q(sigma) = A @ Q + B @ M on each knot segment,
    the cubic through its ends' values Q and second derivatives M."""
    k = np.clip(np.searchsorted(s_knots, sigma, side="right") - 1, 0, len(s_knots) - 2)
    h = s_knots[k + 1] - s_knots[k]
    t = (sigma - s_knots[k]) / h
    rows = np.repeat(np.arange(len(sigma)), 2)
    cols = np.stack([k, k + 1], axis=1).ravel()
    shape = (len(sigma), len(s_knots))
    A = sparse.csr_matrix((np.stack([1.0 - t, t], axis=1).ravel(), (rows, cols)), shape=shape)
    b = (h**2 / 6.0)[:, None] * np.stack([(1.0 - t) ** 3 - (1.0 - t), t**3 - t], axis=1)
    B = sparse.csr_matrix((b.ravel(), (rows, cols)), shape=shape)
    return A, B


def build_knot_nlp(
    deviation: ca.Function,
    kin: Kinematics,
    s_knots: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    *,
    checks: int = NLP_CHECKS,
    cost: str = "smoothness",
    max_iter: int = NLP_MAX_ITER,
    max_wall_time: float = NLP_MAX_WALL_TIME,
    clearance_rows: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> KnotNLP:
    """Build (not solve) the knot NLP of the module docstring for knots at ``s_knots`` (K >= 3).

    Args:
        deviation: ``q -> g`` from ``deviation_function`` (the line and tolerances are in it).
        kin: The robot (joint limits).
        s_knots: Knot path parameters, increasing from 0 to 1, ``(K,)``.
        first, last: Fixed end knots ``(dof,)``.
        checks: Interior check points per knot segment.
        cost: ``"smoothness"`` or ``"length"``.
        max_iter: IPOPT iteration cap; max_wall_time: IPOPT wall-time cap [s].
        clearance_rows: ``(check, G, lb)`` of ``core.clearance.linearized_clearance_rows`` at the
            configurations of the check points ``check_points(s_knots, checks)``: linear rows
            ``G[i] . q(sigma_check[i]) >= lb[i]`` (the avoidance of obstacles, one SQP round).
    """
    k, dof = len(s_knots), kin.dof
    sigma = check_points(s_knots, checks)  # the ends are fixed on the line
    m = len(sigma)
    inner = ca.MX.sym("knots", dof, k - 2)
    moments = ca.MX.sym("moments", dof, k)  # d2q/ds2 at the knots
    Q = ca.horzcat(ca.DM(first), inner, ca.DM(last))  # (dof, K)
    E, F = spline_equations(np.asarray(s_knots, dtype=float))
    A, B = check_weights(np.asarray(s_knots, dtype=float), sigma)
    spline = moments @ ca.DM(E.T) - Q @ ca.DM(F.T)  # = 0: the not-a-knot spline's conditions
    Qc = Q @ ca.DM(sparse.csc_matrix(A.T)) + moments @ ca.DM(sparse.csc_matrix(B.T))  # (dof, M)
    G = deviation.map(m)(Qc)  # (n_g, M), each from 4 knots
    if cost == "smoothness":
        diff = Q[:, 2:] - 2.0 * Q[:, 1:-1] + Q[:, :-2]
    else:
        diff = Q[:, 1:] - Q[:, :-1]
    x = ca.vertcat(ca.vec(inner), ca.vec(moments))
    f = ca.sumsqr(diff)
    linear = ca.vertcat(ca.vec(spline), ca.vec(Qc))
    rows, lb_rows = stacked_rows(clearance_rows, m, dof)
    if rows is not None:
        linear = ca.vertcat(linear, ca.DM(rows) @ ca.vec(Qc))
    options = {
        **IPOPT_OPTIONS,
        "ipopt.max_iter": int(max_iter),
        "ipopt.max_wall_time": float(max_wall_time),
        "print_time": False,
        "error_on_fail": False,
        **derivatives(deviation, x, f, linear, Qc, A, B, k, dof),
    }
    g = ca.vertcat(ca.vec(G), linear)
    solver = ca.nlpsol("knots", "ipopt", {"x": x, "f": f, "g": g}, options)
    lo, hi = kin.position_limits[:, 0], kin.position_limits[:, 1]
    n_dev = G.numel()
    return KnotNLP(
        solver=solver,
        s=np.asarray(s_knots, dtype=float),
        first=np.asarray(first, dtype=float),
        last=np.asarray(last, dtype=float),
        lbx=np.concatenate([np.tile(lo, k - 2), np.full(dof * k, -np.inf)]),
        ubx=np.concatenate([np.tile(hi, k - 2), np.full(dof * k, np.inf)]),
        lbg=np.concatenate([np.full(n_dev, -np.inf), np.zeros(dof * k), np.tile(lo, m), lb_rows]),
        ubg=np.concatenate(
            [np.ones(n_dev), np.zeros(dof * k), np.tile(hi, m), np.full(len(lb_rows), np.inf)]
        ),
        checks=sigma,
    )


def check_points(s_knots: np.ndarray, checks: int = NLP_CHECKS) -> np.ndarray:
    """Path parameters of the NLP's check points (``KnotNLP.checks``) for knots at ``s_knots``."""
    return dense_times(np.asarray(s_knots, dtype=float), checks)[1:-1]


class KnotSolution(NamedTuple):
    """Outcome of one IPOPT solve.

    Attributes:
        positions: Knot positions ``(K, dof)`` (the last iterate, even when not converged).
        status: IPOPT's return status.
        success: IPOPT reports success.
        iterations: IPOPT iterations.
        solve_time: Wall time [s].
    """

    positions: np.ndarray
    status: str
    success: bool
    iterations: int
    solve_time: float


def solve_knot_nlp(problem: KnotNLP, start: np.ndarray, box: float = TRUST_BOX) -> KnotSolution:
    """Solve ``problem`` from knot positions ``start`` (K, dof) (end rows are ignored), each joint
    kept within ``box`` [rad or m] of its start (a trust region: the constraints are steep)."""
    x0 = problem.x_of(start)
    n = problem.n_knot_variables
    lbx, ubx = problem.lbx.copy(), problem.ubx.copy()
    lbx[:n], ubx[:n] = np.maximum(lbx[:n], x0[:n] - box), np.minimum(ubx[:n], x0[:n] + box)
    x0 = np.clip(x0, lbx, ubx)
    t0 = time.perf_counter()
    sol = problem.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=problem.lbg, ubg=problem.ubg)
    elapsed = time.perf_counter() - t0
    stats = problem.solver.stats()
    status = str(stats.get("return_status", "unknown"))
    x = np.asarray(sol["x"], dtype=float).ravel()
    return KnotSolution(
        problem.positions_of(x),
        status,
        status in SUCCESS_STATUSES,
        int(stats.get("iter_count", 0)),
        elapsed,
    )


def knot_parameters(count: int, taylor_s: np.ndarray) -> np.ndarray:
    """``count`` knot path parameters spread like Taylor's knots (their quantiles), 0 and 1 included."""
    s = np.interp(np.linspace(0.0, 1.0, count), np.linspace(0.0, 1.0, len(taylor_s)), taylor_s)
    s[0], s[-1] = 0.0, 1.0
    return s
