"""The per-tick DLS QP of ``resolved_rate_dls`` on one OSQP workspace (``DlsQpSolver``), and the
hook for extra inequality rows (``ExtraRows``: obstacle avoidance). The problem, its settings and
its one-shot path are in ``core.cartesian.rate.qp``."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Protocol

import numpy as np
import osqp
import qpsolvers
import scipy.sparse as sp

from core.cartesian.rate.qp import OSQP_SETTINGS, QpStep, bounded_least_squares
from core.errors import InputError, NoConvergence

_INFINITY = 1e30
"""OSQP's infinity (``OSQP_INFTY``): the bounds of unused extra rows."""


class ExtraRows(Protocol):
    """Extra inequality rows of the DLS QP, per tick: the hook for obstacle avoidance (velocity
    dampers) and any other linear constraint on the joint rates.

    Called with the joint positions ``q`` (dof,) at the start of a tick, it returns at most
    ``capacity`` pairs ``(a, b)``: the row ``a`` (dof,) and its lower bound ``b`` [units of
    ``a . qd``], meaning ``a . qd >= b``. An empty sequence leaves the tick a box-bounded QP.
    """

    capacity: int

    def __call__(self, q: np.ndarray) -> Sequence[tuple[np.ndarray, float]]: ...


class DlsQpSolver:
    """The per-tick QP on one OSQP workspace: set up once, updated in place, warm-started.

    ``P`` is a dense upper triangle in CSC (a fixed sparsity pattern) and ``A = [I; G]``: the rate
    bounds, then ``extra_rows`` dense rows for ``ExtraRows`` (none by default; unused rows are zero
    with infinite bounds). ``solve`` writes new values of ``P``, ``c``, ``l`` and ``u`` (and of
    ``G`` when rows are given or were given the tick before). The update and solve go straight to
    OSQP's extension object when it has the 1.x methods (the Python wrapper's bookkeeping costs
    about 20 us a tick), else through the public API.

    Args:
        dof: Number of joints.
        extra_rows: Most extra inequality rows one tick may add (``ExtraRows.capacity``).
        settings: OSQP settings overriding ``OSQP_SETTINGS``.
    """

    def __init__(self, dof: int, extra_rows: int = 0, **settings: object) -> None:
        self.dof = n = int(dof)
        self.capacity = m = int(extra_rows)
        cols, rows = np.tril_indices(n)  # column by column, rows 0..j: CSC order of triu
        self._rows, self._cols = rows, cols
        self._triu = rows * n + cols  # flat indices of those entries in a C-ordered (n, n) H
        self._diag = np.flatnonzero(rows == cols)  # the diagonal among them
        indptr = np.concatenate([[0], np.cumsum(np.arange(1, n + 1))])
        P = sp.csc_matrix((np.where(rows == cols, 1.0, 0.0), rows, indptr), shape=(n, n))
        # A = [I; G]: column j holds row j, then the m rows of G (explicit zeros keep the pattern).
        a_rows = np.concatenate([[j, *range(n, n + m)] for j in range(n)]).astype(np.int64)
        self._Ax = np.zeros((n, 1 + m))  # column j of A: its CSC values
        self._Ax[:, 0] = 1.0
        A = sp.csc_matrix(
            (self._Ax.ravel(), a_rows, np.arange(0, n * (1 + m) + 1, 1 + m)), shape=(n + m, n)
        )
        self._l, self._u = np.full(n + m, -_INFINITY), np.full(n + m, _INFINITY)
        self._with_rows = False  # G was non-zero at the last update
        self._lam, self._lam2 = 0.0, np.zeros(len(rows))  # the damping term of P_x, cached
        self._osqp = osqp.OSQP()
        self._osqp.setup(
            P, np.zeros(n), A, -np.ones(n + m), np.ones(n + m), **{**OSQP_SETTINGS, **settings}
        )
        ext = getattr(self._osqp, "_solver", None)
        needed = ("update_data_vec", "update_data_mat", "solve", "solution", "info")
        self._ext = ext if all(hasattr(ext, name) for name in needed) else None
        self._solved = int(osqp.SolverStatus.OSQP_SOLVED)
        self._warm = bool({**OSQP_SETTINGS, **settings}["warm_starting"])
        self.status = ""
        """The solver's status at the last ``solve``."""

    def solve(
        self,
        J: np.ndarray,
        V: np.ndarray,
        lam: float,
        lower: np.ndarray,
        upper: np.ndarray,
        out: np.ndarray,
        rows: Sequence[tuple[np.ndarray, float]] = (),
    ) -> tuple[int, bool, float]:
        """The per-tick path of ``step``: writes the rates (clipped into the bounds) into ``out``
        (dof,) and returns ``(iterations, fallback, violation)``; ``rows`` as ``ExtraRows``
        returns them (at most ``capacity``)."""
        H = J.T.dot(J)  # (ndarray.dot: the BLAS call of @ with less overhead; same bits)
        Px = H.take(self._triu)
        if lam != 0.0:  # (adding 0 changes no entry: a diagonal of J^T J is never -0)
            if lam != self._lam:  # lam^2 on the diagonal entries, 0 elsewhere (adding 0 keeps them)
                self._lam, self._lam2 = lam, np.where(self._rows == self._cols, lam * lam, 0.0)
            np.add(Px, self._lam2, out=Px)
        c = -J.T.dot(V)
        box_lower, box_upper = lower, upper
        if self.capacity or rows:
            lower, upper = self._set_rows(rows, lower, upper)
        if self._ext is not None:
            ext = self._ext
            ext.update_data_vec(c, lower, upper)  # (positional: q, l, u)
            if self._with_rows or rows:
                ext.update_data_mat(Px, None, self._Ax.ravel(), None)
            else:
                ext.update_data_mat(Px, None, None, None)  # (P_x, P_i, A_x, A_i)
            ext.solve()
            x, info = ext.solution.x, ext.info
        else:
            A_x = self._Ax.ravel() if self._with_rows or rows else None
            self._osqp.update(Px=Px, Ax=A_x, q=c, l=lower, u=upper)
            result = self._osqp.solve(raise_error=False)
            x, info = result.x, result.info
        self._with_rows = bool(rows)
        iterations, status = int(info.iter), info.status_val
        # x . x is finite iff x is (rates inside finite bounds are far below 1e154): 0.7 against
        # 2.8 us for np.isfinite(x).all()
        fallback = int(status) != self._solved or not math.isfinite(x.dot(x))
        if fallback:
            x = self._exact(J, V, lam, box_lower, box_upper, rows)
            if self._warm:  # (OSQP's warm_start turns warm starting on)
                if rows:
                    self._osqp.warm_start(x=x)
                else:  # the exact primal-dual pair (A = I)
                    H.flat[:: self.dof + 1] += lam * lam
                    y = np.concatenate([-(H @ x + c), np.zeros(self.capacity)])
                    self._osqp.warm_start(x=x, y=y)
        self._info = info
        np.maximum(x, box_lower, out=out)
        np.minimum(out, box_upper, out=out)
        return iterations, fallback, x

    def _set_rows(
        self, rows: Sequence[tuple[np.ndarray, float]], lower: np.ndarray, upper: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Write ``rows`` into ``G`` (zero rows, infinite bounds for the unused ones) and return
        the full bound vectors ``l``, ``u`` (dof + capacity,)."""
        n, count = self.dof, len(rows)
        if count > self.capacity:
            raise InputError(
                f"{count} extra inequality rows exceed the solver's capacity of {self.capacity}",
                field=("constraints",),
            )
        lo, hi = self._l, self._u
        lo[:n], hi[:n] = lower, upper
        G = self._Ax[:, 1:]  # (dof, capacity): G transposed
        G[:, count:] = 0.0
        lo[n + count :] = -_INFINITY
        for i, (a, b) in enumerate(rows):
            G[:, i] = a
            lo[n + i] = b
        return lo, hi

    def _exact(self, J, V, lam, lower, upper, rows) -> np.ndarray:
        """The exact minimizer when OSQP stops short: BVLS for the box, else a dense QP solver."""
        if not rows:
            return bounded_least_squares(J, V, lam, lower, upper)
        G = -np.array([a for a, _ in rows], dtype=float)
        h = -np.array([b for _, b in rows], dtype=float)
        P = J.T @ J + lam * lam * np.eye(self.dof)
        problem = qpsolvers.Problem(
            sp.csc_matrix(P), -(J.T @ V), sp.csc_matrix(G), h, lb=lower, ub=upper
        )
        for solver in ("daqp", "quadprog", "proxqp", "clarabel"):
            if solver in qpsolvers.available_solvers:
                x = qpsolvers.solve_problem(problem, solver=solver).x
                if x is not None and np.isfinite(x).all():
                    return np.minimum(np.maximum(x, lower), upper)
        raise NoConvergence("no QP solver found joint rates within the extra inequality rows")

    def step(
        self,
        J: np.ndarray,
        V: np.ndarray,
        lam: float,
        lower: np.ndarray,
        upper: np.ndarray,
        rows: Sequence[tuple[np.ndarray, float]] = (),
    ) -> QpStep:
        """Rates minimizing ``||J qd - V||^2 + lam^2 ||qd||^2`` within ``lower <= qd <= upper``
        (and ``a . qd >= b`` for each ``(a, b)`` of ``rows``).

        Args:
            J: Task Jacobian ``(m, dof)``.
            V: Task twist ``(m,)``.
            lam: Damping >= 0.
            lower: ``(dof,)`` lower rate bounds [rad/s] (from ``rate_bounds``), <= ``upper``.
            upper: ``(dof,)`` upper rate bounds [rad/s].
            rows: Extra inequality rows (at most ``capacity``).

        When OSQP stops short of its tolerance (``max_iter``, or solved inaccurately: ADMM is slow
        on the ill-conditioned QP of a redundant arm with a joint against a limit), the tick is
        solved exactly (``bounded_least_squares``, or a dense QP solver with extra rows) and OSQP
        is warm-started from that answer.
        """
        start = time.perf_counter()
        x = np.empty(self.dof)
        iterations, fallback, raw = self.solve(J, V, lam, lower, upper, x, rows)
        return QpStep(
            x=x,
            found=True,
            iterations=iterations,
            solve_time=time.perf_counter() - start,
            status=str(self._info.status),
            violation=float(np.abs(raw - x).max()),
            fallback=fallback,
        )
