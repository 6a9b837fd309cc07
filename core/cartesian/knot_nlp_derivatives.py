"""Exact sparse derivatives of the knot NLP, assembled from each check's small SX derivatives
(equal to CasADi's own, several times faster).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from scipy import sparse


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


def derivatives(
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
