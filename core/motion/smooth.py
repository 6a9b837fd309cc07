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
Between those check points a segment may still pass too close: each contact that the quick probe
or the certification of a round's result finds becomes one more linearized row, at that very
configuration (a cutting plane), and the QP is solved again (at most ``MAX_CUTS`` times). A
round's result is kept only once certified as a whole (``core.motion.certify``) and shorter;
otherwise the trust region halves. The shortened path is kept when no round succeeds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import osqp
from scipy import sparse

from core.budget import NO_DEADLINE, Deadline
from core.clearance import linearized_clearance_rows, stacked_rows
from core.motion.certify import Certifier
from core.motion.shorten import path_length

KNOT_SPACING = 0.5
"""[rad] Longest segment of the resampled path."""
MAX_KNOTS = 16
"""Most knots of the smoothed path (the spacing grows for long paths)."""
ACCELERATION_WEIGHT = 0.2
"""Weight of the squared second differences against the squared first differences."""
TRUST_REGION = 0.3
"""[rad] First trust region (per joint, about the current knots)."""
MIN_TRUST = 0.01
"""[rad] Smoothing stops when the trust region shrinks below this."""
MAX_ROUNDS = 2
"""Most QP rounds (a round that fails is tried again with half the trust region)."""
MAX_ACCEPTED = 1
"""Rounds kept before smoothing stops (measured on 20 MBM Panda problems: a second accepted round
shortened the paths by 0.5 % at the median, 7 % at most, for 13 % more CPU per request)."""
MIN_GAIN = 1e-3
"""Relative shortening below which the rounds stop."""
MARGIN = 0.01
"""[m] The linearized rows ask this much beyond each pair's threshold: the smoothed path keeps
this margin where it can, which also keeps its certification cheap (the work of a certification
grows as the margin shrinks)."""
MAX_CUTS = 6
"""Contacts of one round's solution cut off (a row there, solved again) before the round fails."""
SOLVED = (int(osqp.SolverStatus.OSQP_SOLVED), int(osqp.SolverStatus.OSQP_SOLVED_INACCURATE))
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
        t = np.arange(1, n)[:, None] / n
        out.append(knots[k] + t * (knots[k + 1] - knots[k]))
        out.append(knots[k + 1 : k + 2])  # the knot itself, exactly
    return np.vstack(out)


def smooth(
    certifier: Certifier,
    knots: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    deadline: Deadline = NO_DEADLINE,
) -> Smoothed:
    """Smooth the certified path through ``knots`` ``(K, dof)`` within the joint limits ``lower``,
    ``upper`` ``(dof,)`` (bounded by counts, not by the clock: ``MAX_ROUNDS`` rounds of at most
    ``MAX_CUTS`` re-solves)."""
    best = np.asarray(knots, dtype=float)
    current = resample(best)
    if len(current) < 3:
        return Smoothed(best, 0, 0)
    best_length = path_length(best)
    trust, rounds, accepted = TRUST_REGION, 0, 0
    while rounds < MAX_ROUNDS and trust >= MIN_TRUST:
        deadline.check("smoothing the path")
        rounds += 1
        candidate = _round(certifier, _Qp(certifier, current, lower, upper), trust, best_length)
        if candidate is None:
            trust /= 2
            continue
        length = path_length(candidate)
        gain = (best_length - length) / best_length
        best, best_length, current = candidate, length, candidate
        accepted += 1
        if gain < MIN_GAIN or accepted >= MAX_ACCEPTED:
            break
    return Smoothed(best, rounds, accepted)


def _round(certifier: Certifier, qp: _Qp, trust: float, longest: float) -> np.ndarray | None:
    """The QP's knots once certified and shorter than ``longest``, cutting off each contact the
    probe or the certification finds (a row at that configuration) and solving again, at most
    ``MAX_CUTS`` times; None when that does not succeed."""
    for _ in range(MAX_CUTS + 1):
        candidate = qp.solve(trust)
        if candidate is None or path_length(candidate) >= longest:
            return None
        where = certifier.first_contact(candidate)
        if where is None:
            cert = certifier.path(candidate)
            if cert.ok:
                return candidate
            if not cert.contact or cert.failed_at is None:
                return None
            where = _locate(candidate, cert.failed_at)
        qp.cut(candidate, *where)
    return None


def _locate(knots: np.ndarray, s: float) -> tuple[int, float]:
    """``(segment, fraction)`` of arc length ``s`` along the segments through ``knots``."""
    seg = np.linalg.norm(np.diff(knots, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1))
    return k, float(np.clip((s - cum[k]) / seg[k], 0.0, 1.0)) if seg[k] > 0 else 0.0


class _Qp:
    """The QP of one round about the knots ``q0`` ``(N, dof)`` (module docstring), built once;
    ``cut`` adds the linearized rows at a configuration of a rejected candidate (segment k at
    fraction t, as a combination of its two knots)."""

    def __init__(
        self, certifier: Certifier, q0: np.ndarray, lower: np.ndarray, upper: np.ndarray
    ) -> None:
        N, dof = q0.shape
        self.certifier, self.q0, self.lower, self.upper = certifier, q0, lower, upper
        D1 = sparse.diags([-np.ones(N - 1), np.ones(N - 1)], [0, 1], shape=(N - 1, N))
        D2 = sparse.diags(
            [np.ones(N - 2), -2 * np.ones(N - 2), np.ones(N - 2)], [0, 1, 2], shape=(N - 2, N)
        )
        H = (D1.T @ D1 + ACCELERATION_WEIGHT * D2.T @ D2).tocsc()
        self.inner, fixed = np.arange(1, N - 1), np.array([0, N - 1])
        eye = sparse.identity(dof, format="csc")
        self.P = sparse.kron(2 * H[self.inner][:, self.inner], eye, format="csc")
        self.c = sparse.kron(2 * H[self.inner][:, fixed], eye) @ q0[fixed].ravel()
        self.cols = (dof * self.inner[:, None] + np.arange(dof)).ravel()
        self.ends = (dof * fixed[:, None] + np.arange(dof)).ravel()
        # rows at interior knots and segment middles, as rows over every knot
        mix = sparse.vstack([sparse.identity(N, format="csr")[self.inner], 0.5 * abs(D1)]).tocsr()
        self.rows: list[sparse.csc_matrix] = []
        self.bounds: list[np.ndarray] = []
        self._add(mix, mix @ q0)

    def _add(self, mix: sparse.csr_matrix, checks: np.ndarray) -> None:
        """Linearized rows at the configurations ``checks`` = ``mix @ knots`` (new knots)."""
        N, dof = self.q0.shape
        rows = linearized_clearance_rows(self.certifier.clearance, checks, margin=MARGIN)
        W, lb = stacked_rows(rows, len(checks), dof)
        if W is None:
            return
        M = W @ sparse.kron(mix, sparse.identity(dof, format="csc"), format="csc")
        self.rows.append(M[:, self.cols])
        self.bounds.append(lb - M[:, self.ends] @ self.q0[[0, N - 1]].ravel())

    def cut(self, candidate: np.ndarray, k: int, t: float) -> None:
        """Rows at ``candidate``'s segment ``k`` fraction ``t`` (where it is too close)."""
        N = len(self.q0)
        mix = sparse.csr_matrix(([1.0 - t, t], ([0, 0], [k, k + 1])), shape=(1, N))
        self._add(mix, mix @ candidate)

    def solve(self, trust: float) -> np.ndarray | None:
        """The QP's knots within ``trust`` [rad] of ``q0``, or None when OSQP fails."""
        n, dof = len(self.inner), self.q0.shape[1]
        inner = self.q0[self.inner]
        box_lo = np.maximum(np.repeat(self.lower[None], n, 0), inner - trust).ravel()
        box_hi = np.minimum(np.repeat(self.upper[None], n, 0), inner + trust).ravel()
        lb = np.concatenate([box_lo, *self.bounds])
        ub = np.concatenate([box_hi, np.full(len(lb) - len(box_lo), np.inf)])
        solver = osqp.OSQP()
        solver.setup(
            P=sparse.triu(self.P, format="csc"),
            q=np.asarray(self.c),
            A=sparse.vstack([sparse.identity(n * dof, format="csc"), *self.rows], format="csc"),
            l=lb,
            u=ub,
            **OSQP_SETTINGS,
        )
        solver.warm_start(x=inner.ravel())
        result = solver.solve(raise_error=False)
        if result.info.status_val not in SOLVED:
            return None
        x = np.clip(result.x.reshape(n, dof), self.lower, self.upper)
        return np.vstack([self.q0[:1], x, self.q0[-1:]])
