"""Smoothing a certified joint path: a TrajOpt-style sequence of QPs over its knots (OSQP).

The shortened path is resampled to knots at most ``KNOT_SPACING`` apart (at most ``MAX_KNOTS``),
its ends fixed. Each round solves the QP

    minimize    sum_k |q_{k+1} - q_k|^2 + ACCELERATION_WEIGHT sum_k |q_{k+1} - 2 q_k + q_{k-1}|^2
    subject to  lower <= q_k <= upper,   |q_k - q_k^0| <= trust (per joint),
                g . (c - c^0) >= threshold + margin - d       (linearized clearance)

about the current knots q^0 (Schulman et al., "Finding locally optimal, collision-free
trajectories with sequential convex optimization", RSS 2013): the clearance rows are those of
``core.clearance.linearized_clearance_rows`` (the closest pair of each group within reach, scaled
to meters along the distance's gradient), taken at every interior knot and at the middle of every
segment (``c`` a knot or the mean of two). With squared segment lengths as the cost, the optimum
spaces the knots evenly along a path pulled taut against the obstacles: smoothing shortens.
Every round's result is certified as a whole (``core.motion.certify``) and kept only then, and
only when it is shorter; otherwise the trust region halves. The shortened path is kept when no
round succeeds.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import osqp
from scipy import sparse

from core.clearance import linearized_clearance_rows, stacked_rows
from core.motion.certify import Certifier
from core.motion.shorten import path_length

KNOT_SPACING = 0.35
"""[rad] Longest segment of the resampled path."""
MAX_KNOTS = 20
"""Most knots of the smoothed path (the spacing grows for long paths)."""
ACCELERATION_WEIGHT = 0.2
"""Weight of the squared second differences against the squared first differences."""
TRUST_REGION = 0.3
"""[rad] First trust region (per joint, about the current knots)."""
MIN_TRUST = 0.01
"""[rad] Smoothing stops when the trust region shrinks below this."""
MAX_ROUNDS = 3
"""Most QP rounds."""
MIN_GAIN = 1e-3
"""Relative shortening below which the rounds stop."""
OSQP_SETTINGS: dict[str, float | int | bool] = {
    "eps_abs": 1e-6,
    "eps_rel": 1e-6,
    "max_iter": 4000,
    "polishing": True,
    "verbose": False,
}


@dataclass(frozen=True)
class Smoothed:
    """A smoothed path.

    Attributes:
        knots: ``(K, dof)`` certified (the input when no round succeeded).
        rounds: QP rounds solved.
        accepted: Rounds whose result was certified and kept.
    """

    knots: np.ndarray
    rounds: int
    accepted: int


def resample(knots: np.ndarray, spacing: float = KNOT_SPACING, most: int = MAX_KNOTS) -> np.ndarray:
    """Knots on the same segments, each segment split evenly into pieces at most ``spacing`` long
    (longer when that would give more than ``most`` knots); the input knots are kept."""
    knots = np.asarray(knots, dtype=float)
    seg = np.linalg.norm(np.diff(knots, axis=0), axis=1)
    spacing = max(spacing, float(seg.sum()) / max(most - len(knots), 1))
    out = [knots[:1]]
    for k, length in enumerate(seg):
        n = max(int(np.ceil(length / spacing)), 1)
        t = np.arange(1, n + 1)[:, None] / n
        out.append(knots[k] + t * (knots[k + 1] - knots[k]))
    return np.vstack(out)


def smooth(
    certifier: Certifier,
    knots: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    until: float,
) -> Smoothed:
    """Smooth the certified path through ``knots`` ``(K, dof)`` within the joint limits ``lower``,
    ``upper`` ``(dof,)`` until ``until`` (a ``time.perf_counter()`` value)."""
    best = np.asarray(knots, dtype=float)
    current = resample(best)
    if len(current) < 3:
        return Smoothed(best, 0, 0)
    best_length = path_length(best)
    trust, rounds, accepted = TRUST_REGION, 0, 0
    while rounds < MAX_ROUNDS and trust >= MIN_TRUST and time.perf_counter() < until:
        rounds += 1
        candidate = _qp_round(certifier, current, lower, upper, trust)
        if candidate is None:
            trust /= 2
            continue
        length = path_length(candidate)
        if (
            length < best_length
            and certifier.probably_clear(candidate)
            and certifier.path(candidate).ok
        ):
            gain = (best_length - length) / best_length
            best, best_length, current = candidate, length, candidate
            accepted += 1
            if gain < MIN_GAIN:
                break
        else:
            trust /= 2
    return Smoothed(best, rounds, accepted)


def _qp_round(
    certifier: Certifier, q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, trust: float
) -> np.ndarray | None:
    """One QP about the knots ``q0`` ``(N, dof)``: the new knots, or None when OSQP fails."""
    N, dof = q0.shape
    n = N - 2
    D1 = sparse.diags([-np.ones(N - 1), np.ones(N - 1)], [0, 1], shape=(N - 1, N))
    D2 = sparse.diags(
        [np.ones(N - 2), -2 * np.ones(N - 2), np.ones(N - 2)], [0, 1, 2], shape=(N - 2, N)
    )
    H = (D1.T @ D1 + ACCELERATION_WEIGHT * D2.T @ D2).tocsc()
    inner = np.arange(1, N - 1)
    fixed = np.array([0, N - 1])
    eye = sparse.identity(dof, format="csc")
    P = sparse.kron(2 * H[inner][:, inner], eye, format="csc")
    c = sparse.kron(2 * H[inner][:, fixed], eye) @ q0[fixed].ravel()
    # clearance rows at interior knots and segment middles, as rows over every knot
    A_checks = sparse.vstack([sparse.identity(N, format="csr")[inner], 0.5 * (abs(D1))]).tocsr()
    checks = A_checks @ q0
    W, lb = stacked_rows(linearized_clearance_rows(certifier.clearance, checks), len(checks), dof)
    box_lo = np.maximum(np.repeat(lower[None], n, 0), q0[inner] - trust).ravel()
    box_hi = np.minimum(np.repeat(upper[None], n, 0), q0[inner] + trust).ravel()
    rows = [sparse.identity(n * dof, format="csc")]
    lo, hi = [box_lo], [box_hi]
    if W is not None:
        M = W @ sparse.kron(A_checks, eye, format="csc")  # rows over the stacked knots
        cols = (dof * inner[:, None] + np.arange(dof)).ravel()
        ends = (dof * fixed[:, None] + np.arange(dof)).ravel()
        rows.append(M[:, cols])
        lo.append(lb - M[:, ends] @ q0[fixed].ravel())
        hi.append(np.full(len(lb), np.inf))
    solver = osqp.OSQP()
    solver.setup(
        P=sparse.triu(P, format="csc"),
        q=np.asarray(c),
        A=sparse.vstack(rows, format="csc"),
        l=np.concatenate(lo),
        u=np.concatenate(hi),
        **OSQP_SETTINGS,
    )
    solver.warm_start(x=q0[inner].ravel())
    result = solver.solve(raise_error=False)
    if result.info.status_val not in (
        osqp.SolverStatus.OSQP_SOLVED,
        osqp.SolverStatus.OSQP_SOLVED_INACCURATE,
    ):
        return None
    x = np.clip(result.x.reshape(n, dof), lower, upper)
    return np.vstack([q0[:1], x, q0[-1:]])
