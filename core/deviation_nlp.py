"""Bounded deviation as constraints: knot configurations are the decision variables of an NLP.

The returned joint path is the same kind as Taylor's (``core.deviation.KnotPath``: the C2 cubic
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
assembled from each check's small SX derivatives (``_derivatives``; equal to CasADi's own, several
times faster). Each solve keeps every knot joint within ``TRUST_BOX`` of its warm start (the
constraints are steep: 1 mm is a few mrad) and has IPOPT iteration and wall-time caps.

Knot-count search: Taylor's knots (after the dense measurement of the trajectory they give) are
feasible with K_T knots. First the straight joint path (2 knots) is checked; then counts from 3
upward (3, 5, 8, 12, ...: x1.5) until one is accepted, then bisection below it. Each solve is
warm-started from the best path known (the spline through the best knots so far, resampled at the new
s_k); the s_k follow the density of Taylor's knots (their quantiles). A solution is accepted when a
numpy check of the spline, denser than the NLP's checks, finds it within ``ACCEPT`` of the
tolerances and inside the joint limits, whatever IPOPT's status (feasibility is what counts, not
optimality of the smoothness). The winner goes through the same timing, dense measurement of the
returned trajectory and splitting as Taylor's (``core.deviation.finish_knots``).

Failures: when no count below K_T is accepted, ``TimeBudgetExceeded`` if a wall-time cap (or
``task.deadline``) stopped the search, ``NoConvergence`` if a solve stopped at the iteration cap;
otherwise (IPOPT found each smaller count infeasible, or its solution failed the numpy check)
Taylor's knots are returned, with a warning.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import casadi as ca
import numpy as np
from scipy import sparse

from core.cartesian_task import CartesianResult, CartesianTask, validated_line
from core.deviation import (
    MARGIN,
    PATH_CHECKS,
    KnotPath,
    Knots,
    TaylorStats,
    check_knot_path,
    dense_times,
    finish_knots,
    goal_configuration,
    measured_knots,
    path_deviation,
    plan_partial,
    taylor_knots,
)
from core.errors import InputError, NoConvergence, TimeBudgetExceeded
from core.geometry.so3 import skew
from core.kinematics import Kinematics
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
_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
_TIME_STATUSES = ("Maximum_WallTime_Exceeded", "Maximum_CpuTime_Exceeded")
_ITERATION_CAP = ("Maximum_Iterations_Exceeded",)


def _clip01(x: ca.SX) -> ca.SX:
    return ca.fmin(ca.fmax(x, 0.0), 1.0)


def deviation_constraints(
    line: StraightLine, p: ca.SX, R: ca.SX, tol_p: float, tol_o: float, margin: float = MARGIN
) -> list[ca.SX]:
    """Scaled deviation constraints (each <= 1) of one tool pose (p (3,), R (3, 3)) from ``line``.

    Position and orientation at the closest line point of ``StraightLine.deviation`` (s*: the
    position and orientation projections weighed by ``tol_p`` [m] and ``tol_o`` [rad]), and the
    orientation also at the closest point by position alone (s_p, where the position deviation is
    the plain distance to the segment), so the bound holds for either way of measuring it. The
    bounds are ``margin`` times the tolerances. ``position_xy``: the position constraint only.
    """
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
        K = skew(line.rotvec / theta) if theta > 1e-12 else np.zeros((3, 3))
        scale = 2.0 * (1.0 - np.cos(margin * tol_o))

        def misalignment(at: ca.SX) -> ca.SX:
            # 3 - tr(R_line(at)^T R) = 2 (1 - cos angle), R_line(at) = R0 exp(at * rotvec)
            E_line = ca.DM.eye(3) + ca.sin(at * theta) * K + (1.0 - ca.cos(at * theta)) * (K @ K)
            return (3.0 - ca.trace(E_line.T @ E)) / scale

        out.append(misalignment(s))
        if length_sq > 1e-12:
            out.append(misalignment(_clip01(s_pos)))
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
    fk: ca.Function, line: StraightLine, position_tolerance: float, orientation_tolerance: float
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
    """
    k, dof = len(s_knots), kin.dof
    sigma = dense_times(s_knots, checks)[1:-1]  # the ends are fixed on the line
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
    options = {
        **IPOPT_OPTIONS,
        "ipopt.max_iter": int(max_iter),
        "ipopt.max_wall_time": float(max_wall_time),
        "print_time": False,
        "error_on_fail": False,
        **_derivatives(deviation, x, f, linear, Qc, A, B, k, dof),
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
        lbg=np.concatenate([np.full(n_dev, -np.inf), np.zeros(dof * k), np.tile(lo, m)]),
        ubg=np.concatenate([np.ones(n_dev), np.zeros(dof * k), np.tile(hi, m)]),
        checks=sigma,
    )


def _terms(A: sparse.csr_matrix, B: sparse.csr_matrix, k: int, dof: int) -> tuple[np.ndarray, ...]:
    """The spline at check j is q_j = C_j x: for each check, joint d and term a (the two knots and
    the two second derivatives of its segment), the index of x and the weight; index -1 for the
    fixed end knots. Returns ``(index (M, dof, 4), weight (M, 4))``."""
    m = A.shape[0]
    seg = np.asarray(A.indices).reshape(m, 2)  # the segment's two knots
    weight = np.concatenate([np.asarray(A.data).reshape(m, 2), np.asarray(B.data).reshape(m, 2)], 1)
    n_q = dof * (k - 2)
    d = np.arange(dof)[None, :, None]
    knot = seg[:, None, :]
    q_index = np.where((knot >= 1) & (knot <= k - 2), d + dof * (knot - 1), -1)
    m_index = n_q + d + dof * knot
    return np.concatenate([q_index, m_index], axis=2), weight


def _scattered(
    shape: tuple[int, int],
    rows: np.ndarray,
    cols: np.ndarray,
    src: np.ndarray,
    w: np.ndarray,
    n_src: int,
) -> tuple[ca.Sparsity, sparse.csc_matrix]:
    """A sparse matrix whose entry (rows[i], cols[i]) sums w[i] * values[src[i]]: its sparsity and
    the (nnz, n_src) scatter matrix from the values to its nonzeros (column-major, as CasADi's)."""
    key = rows + shape[0] * cols
    keys, inverse = np.unique(key, return_inverse=True)
    scatter = sparse.csc_matrix((w, (inverse, src)), shape=(len(keys), n_src))
    sp = ca.Sparsity.triplet(
        shape[0], shape[1], (keys % shape[0]).tolist(), (keys // shape[0]).tolist()
    )
    return sp, scatter


def _derivatives(
    deviation: ca.Function,
    x: ca.MX,
    f: ca.MX,
    linear: ca.MX,
    Qc: ca.MX,
    A: sparse.csr_matrix,
    B: sparse.csr_matrix,
    k: int,
    dof: int,
) -> dict[str, ca.Function]:
    """``jac_g`` and ``hess_lag`` for IPOPT, assembled from each check's own derivatives.

    The spline at check j is q_j = C_j x (``_terms``): the deviation constraints' Jacobian rows
    are J_j C_j and their Hessian terms C_j^T H_j C_j, with J_j, H_j the (small, SX) Jacobian and
    Hessian of g in q, mapped over the checks and scattered by constant sparse matrices. The
    objective and the other constraints are quadratic or linear: constant terms. CasADi's own
    derivatives of this graph are the same (tested) but several times slower.
    """
    n_x, m = x.numel(), Qc.numel() // dof
    n_l = deviation.size1_out(0)  # constraints per check
    n_dev = n_l * m
    index, weight = _terms(A, B, k, dof)
    q = ca.SX.sym("q", dof)
    lam = ca.SX.sym("lam", n_l)
    local = ca.Function("local", [q], [ca.jacobian(deviation(q), q)])
    H_local = ca.Function("h", [q, lam], [ca.hessian(ca.dot(lam, deviation(q)), q)[0]])
    xs = ca.MX.sym("x", n_x)
    Qc_x = ca.Function("qc", [x], [ca.reshape(Qc, dof, m)])(xs)

    # Jacobian: row i + n_l j, column index[j, d, a], weight weight[j, a] * J_j[i, d].
    j, i, d, a = np.meshgrid(
        np.arange(m), np.arange(n_l), np.arange(dof), np.arange(4), indexing="ij"
    )
    cols = index[j, d, a]
    ok = cols >= 0
    sp, scatter = _scattered(
        (n_dev, n_x),
        (i + n_l * j)[ok],
        cols[ok],
        (i + n_l * (d + dof * j))[ok],  # vec of the mapped (n_l, dof * M) Jacobians
        weight[j, a][ok],
        n_l * dof * m,
    )
    Js = local.map(m)(Qc_x)
    J_dev = ca.MX(sp, ca.DM(scatter) @ ca.vec(ca.densify(Js)))
    J_linear = ca.DM(ca.Function("jl", [x], [ca.jacobian(linear, x)])(np.zeros(n_x)))
    g = ca.Function(
        "g", [x], [ca.vertcat(ca.vec(deviation.map(m)(ca.reshape(Qc, dof, m))), linear)]
    )
    jac_g = ca.Function(
        "jac_g",
        [xs, ca.MX.sym("p", 0)],
        [g(xs), ca.vertcat(J_dev, J_linear)],
        ["x", "p"],
        ["g", "jac_g_x"],
    )

    # Hessian (upper triangle): entry (index[j,d,a], index[j,e,b]) += w_a w_b H_j[d, e].
    j, d, e, a, b = np.meshgrid(
        np.arange(m), np.arange(dof), np.arange(dof), np.arange(4), np.arange(4), indexing="ij"
    )
    u, v = index[j, d, a], index[j, e, b]
    ok = (u >= 0) & (v >= 0) & (u <= v)
    Hf = sparse.coo_matrix(
        np.triu(np.asarray(ca.DM(ca.Function("hf", [x], [ca.hessian(f, x)[0]])(np.zeros(n_x)))))
    )
    n_src = dof * dof * m
    sp, scatter = _scattered(
        (n_x, n_x),
        np.concatenate([u[ok], Hf.row]),
        np.concatenate([v[ok], Hf.col]),
        np.concatenate([(d + dof * e + dof * dof * j)[ok], np.full(Hf.nnz, n_src)]),
        np.concatenate([(weight[j, a] * weight[j, b])[ok], Hf.data]),
        n_src + 1,  # the last source: the objective's multiplier
    )
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_dev + linear.numel())
    Hs = H_local.map(m)(Qc_x, ca.reshape(lam_g[:n_dev], n_l, m))  # (dof, dof * M)
    H = ca.MX(sp, ca.DM(scatter) @ ca.vertcat(ca.vec(ca.densify(Hs)), lam_f))
    hess_lag = ca.Function(
        "hess_lag",
        [xs, ca.MX.sym("p", 0), lam_f, lam_g],
        [H],
        ["x", "p", "lam_f", "lam_g"],
        ["triu_hess_gamma_x_x"],
    )
    return {"jac_g": jac_g, "hess_lag": hess_lag}


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
        status in _SUCCESS,
        int(stats.get("iter_count", 0)),
        elapsed,
    )


def knot_parameters(count: int, taylor_s: np.ndarray) -> np.ndarray:
    """``count`` knot path parameters spread like Taylor's knots (their quantiles), 0 and 1 included."""
    s = np.interp(np.linspace(0.0, 1.0, count), np.linspace(0.0, 1.0, len(taylor_s)), taylor_s)
    s[0], s[-1] = 0.0, 1.0
    return s


def _symbolic_fk(kin: Kinematics) -> ca.Function:
    """The robot's symbolic FK: its own ``fk_casadi()`` when it has one, else ``robots.symbolic``."""
    own = getattr(kin, "fk_casadi", None)
    if callable(own):
        return own()
    from robots.symbolic import fk_casadi  # core stays importable without robots/

    return fk_casadi(kin)


def plan_bounded_deviation_nlp(
    task: CartesianTask,
    *,
    checks: int = NLP_CHECKS,
    cost: str = "smoothness",
    max_iter: int = NLP_MAX_ITER,
    max_wall_time: float = NLP_MAX_WALL_TIME,
    total_wall_time: float = NLP_TOTAL_WALL_TIME,
) -> CartesianResult:
    """Bounded deviation with the knots optimized by IPOPT (see the module docstring).

    Args:
        task: The Cartesian task (tolerances, timing, sampling, deadline).
        checks: Interior check points per knot segment, >= 1.
        cost: ``"smoothness"`` (squared second differences of the knots) or ``"length"``.
        max_iter: IPOPT iterations per solve, >= 1.
        max_wall_time: [s] IPOPT wall time per solve, > 0 (also capped by ``task.deadline``).
        total_wall_time: [s] for the whole knot-count search.

    Raises what Taylor's method raises, and ``NoConvergence`` when no solve converged (iteration
    cap), ``TimeBudgetExceeded`` when the wall-time caps or the deadline stopped it. With
    ``task.allow_partial`` a failure located at ``s`` plans the reachable prefix instead.
    """
    if cost not in COSTS:
        raise InputError(f"cost must be one of {', '.join(COSTS)}", field=("cost",))
    if checks < 1 or max_iter < 1 or not max_wall_time > 0 or not total_wall_time > 0:
        raise InputError("checks and max_iter must be >= 1, wall times > 0", field=("solver",))
    options = (checks, cost, max_iter, max_wall_time, total_wall_time)
    return plan_partial(task, lambda t: _plan_nlp(t, *options))


def _plan_nlp(
    task: CartesianTask,
    checks: int,
    cost: str,
    max_iter: int,
    max_wall_time: float,
    total_wall_time: float,
) -> CartesianResult:
    line = validated_line(task)
    started = time.perf_counter()
    kin, deadline = task.robot, task.deadline
    tol_p, tol_o = task.position_tolerance, task.orientation_tolerance
    stats = TaylorStats()
    q_goal, warnings, ref = goal_configuration(kin, line, task.q_start, task.q_goal, deadline)
    taylor = taylor_knots(
        kin, line, task.q_start, q_goal, tol_p, tol_o, deadline=deadline, stats=stats, reference=ref
    )
    midpoint_count = len(taylor)
    taylor = check_knot_path(
        kin, line, taylor, tol_p, tol_o, deadline=deadline, stats=stats, reference=ref
    )
    # Taylor's final knots (what ``bounded_deviation`` returns): the count to beat, the warm start.
    taylor, _ = measured_knots(task, line, taylor, stats=stats, reference=ref)
    stats = replace(stats, resplits=0)
    search = _KnotSearch(task, line, taylor, checks, cost, max_iter, max_wall_time, total_wall_time)
    best = search.run()
    diagnostics: dict[str, Any] = {
        "midpoint_knot_count": midpoint_count,
        "taylor_knot_count": len(taylor),
        "knot_counts_tried": [a["knots"] for a in search.attempts],
        "attempts": search.attempts,
        "ipopt_iterations": sum(a["iterations"] for a in search.attempts),
        "nlp_solve_time_ms": 1e3 * sum(a["solve_time_s"] for a in search.attempts),
        "knot_time_ms": 1e3 * (time.perf_counter() - started),
    }
    if best is taylor and search.attempts:
        warnings = [*warnings, "the NLP found no knot set smaller than Taylor's; returning those"]
    return finish_knots(
        task, line, best, stats=stats, diagnostics=diagnostics, warnings=warnings, reference=ref
    )


class _KnotSearch:
    """The smallest accepted knot count between 3 and Taylor's count (see the module docstring)."""

    def __init__(
        self,
        task: CartesianTask,
        line: StraightLine,
        taylor: Knots,
        checks: int,
        cost: str,
        max_iter: int,
        max_wall_time: float,
        total_wall_time: float,
    ) -> None:
        self.task, self.line, self.taylor = task, line, taylor
        self.checks, self.cost, self.max_iter = checks, cost, max_iter
        self.max_wall_time = max_wall_time
        self.end = time.monotonic() + total_wall_time
        with SYMBOLIC_LOCK:
            self.deviation = deviation_function(
                _symbolic_fk(task.robot), line, task.position_tolerance, task.orientation_tolerance
            )
        self.attempts: list[dict[str, Any]] = []

    def run(self) -> Knots:
        """Galloping up from 3 knots (x1.5) to the first accepted count, then bisection below it."""
        best, lo, hi = self.taylor, 2, len(self.taylor)
        straight = Knots(np.array([0.0, 1.0]), self.taylor.positions[[0, -1]])
        if hi > 2 and self._within(straight):  # joint interpolation alone keeps the bound
            self.attempts.append(
                {"knots": 2, "status": "no_variables", "iterations": 0, "solve_time_s": 0.0,
                 "accepted": True}
            )  # fmt: skip
            return straight
        capped = False  # some count failed at the iteration cap (not shown infeasible)
        timed_out = False
        count = 3
        while count < hi and not timed_out:
            found, status = self._try(count, best)
            if found is not None:
                best, hi = found, count
                break
            lo, timed_out = count, status in _TIME_STATUSES
            capped = capped or status in _ITERATION_CAP
            count = max(count + 1, int(np.ceil(1.5 * count)))
        while hi - lo > 1 and not timed_out:
            count = (lo + hi) // 2
            found, status = self._try(count, best)
            if found is not None:
                best, hi = found, count
            else:
                lo, timed_out = count, status in _TIME_STATUSES
                capped = capped or status in _ITERATION_CAP
        if best is not self.taylor or len(self.taylor) <= 3:
            return best
        tried = [a["status"] for a in self.attempts]
        if timed_out:
            raise TimeBudgetExceeded(
                "the knot NLP reached its wall-time cap before finding a solution",
                extra={"statuses": tried},
            )
        if capped:
            raise NoConvergence(
                "IPOPT did not converge for any knot count below Taylor's "
                f"{len(self.taylor)} (iteration cap {self.max_iter})",
                extra={"statuses": tried},
            )
        return best

    def _try(self, count: int, best: Knots) -> tuple[Knots | None, str]:
        task = self.task
        task.deadline.check("bounded deviation NLP")
        # Half the time left at most: the rest is for timing and measuring the result.
        budget = min(
            self.max_wall_time, 0.5 * task.deadline.remaining(), self.end - time.monotonic()
        )
        if budget <= 0.0:
            return None, "Maximum_WallTime_Exceeded"
        s = knot_parameters(count, self.taylor.s)
        with SYMBOLIC_LOCK:
            problem = build_knot_nlp(
                self.deviation,
                task.robot,
                s,
                best.positions[0],
                best.positions[-1],
                checks=self.checks,
                cost=self.cost,
                max_iter=self.max_iter,
                max_wall_time=budget,
            )
        sol = solve_knot_nlp(problem, KnotPath(best)(s))
        knots = Knots(s, sol.positions)
        ok = self._within(knots)  # IPOPT's optimality is not needed, feasibility is
        self.attempts.append(
            {
                "knots": count,
                "status": sol.status,
                "iterations": sol.iterations,
                "solve_time_s": sol.solve_time,
                "accepted": ok,
            }
        )
        if sol.status in _TIME_STATUSES and task.deadline.expired():
            task.deadline.check("bounded deviation NLP")
        return (knots if ok else None), sol.status

    def _within(self, knots: Knots) -> bool:
        """The spline through ``knots`` stays within ``ACCEPT`` of the tolerances and the limits."""
        task, kin = self.task, self.task.robot
        path = KnotPath(knots)
        s = dense_times(knots.s, PATH_CHECKS)
        dev = path_deviation(
            kin, self.line, path, s, task.position_tolerance, task.orientation_tolerance
        )
        q = path(s)
        lo, hi = kin.position_limits[:, 0], kin.position_limits[:, 1]
        return bool(
            dev.position.max() <= ACCEPT * task.position_tolerance
            and dev.orientation.max() <= ACCEPT * task.orientation_tolerance
            and np.all((q >= lo) & (q <= hi))
        )
