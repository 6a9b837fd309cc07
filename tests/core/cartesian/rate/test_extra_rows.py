"""The hook for extra inequality rows of the DLS QP (``ExtraRows``, for obstacle avoidance): rows
``a . qd >= b`` on the per-tick OSQP workspace, checked against the closed-form KKT solution with
the row active, and a controller run whose rows hold a joint still."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core.cartesian.rate.control import simulate
from core.cartesian.rate.tick_qp import DlsQpSolver
from core.errors import InputError
from tests.core.cartesian.rate.scenarios import SCENARIOS


def _problem(seed: int):
    rng = np.random.default_rng(seed)
    J, V = rng.normal(size=(6, 7)), rng.normal(size=6)
    lam = 0.05
    H = J.T @ J + lam * lam * np.eye(7)
    free = np.linalg.solve(H, J.T @ V)  # the minimizer without constraints
    a = rng.normal(size=7)
    b = float(a @ free) + 0.5  # the free minimizer violates a . qd >= b
    return J, V, lam, H, a, b


@pytest.mark.parametrize("seed", range(5))
def test_active_row_gives_the_kkt_solution(seed):
    J, V, lam, H, a, b = _problem(seed)
    kkt = np.block([[H, a[:, None]], [a[None, :], np.zeros((1, 1))]])
    exact = np.linalg.solve(kkt, np.concatenate([J.T @ V, [b]]))[:7]
    solver = DlsQpSolver(7, extra_rows=3)
    wide = np.full(7, 100.0)
    step = solver.step(J, V, lam, -wide, wide, rows=[(a, b)])
    assert np.abs(step.x - exact).max() <= 1e-6, (step.x, exact)
    assert a @ step.x >= b - 1e-6
    # The rows are per tick: without them the next solve is the free minimizer again.
    free = solver.step(J, V, lam, -wide, wide)
    assert np.abs(free.x - np.linalg.solve(H, J.T @ V)).max() <= 1e-5  # (H has eigenvalues ~ lam^2)


def test_spare_capacity_changes_nothing_and_is_enforced():
    J, V, lam, _, a, b = _problem(7)
    lower, upper = np.full(7, -0.3), np.full(7, 0.3)
    plain = DlsQpSolver(7).step(J, V, lam, lower, upper)
    spare = DlsQpSolver(7, extra_rows=4).step(J, V, lam, lower, upper)
    assert np.abs(plain.x - spare.x).max() <= 1e-8
    with pytest.raises(InputError):
        DlsQpSolver(7, extra_rows=1).step(J, V, lam, lower, upper, rows=[(a, b), (-a, -b)])


class _HoldJoint:
    """Rows that keep joint ``j`` from moving either way: ``qd_j >= 0`` and ``-qd_j >= 0``."""

    capacity = 2

    def __init__(self, dof: int, j: int) -> None:
        self.e = np.eye(dof)[j]
        self.calls = 0

    def __call__(self, q):
        self.calls += 1
        return [(self.e, 0.0), (-self.e, 0.0)]


def test_controller_applies_rows_every_tick():
    pytest.importorskip("robots.registry")
    build, method = SCENARIOS["ur5_1s_dls"]
    task = dataclasses.replace(build(), allow_partial=True, allow_violations=True)
    hold = _HoldJoint(task.robot.dof, 0)
    run = simulate(task, method, extra_rows=hold)
    assert hold.calls == len(run.sigma)
    assert np.abs(run.rates[:, 0]).max() <= 1e-7
    assert np.abs(run.positions[:, 0] - task.q_start[0]).max() <= 1e-9
    free = simulate(task, method)
    assert np.abs(free.rates[:, 0]).max() > 1e-2  # the line does need joint 0
    with pytest.raises(InputError):
        simulate(task, "resolved_rate", extra_rows=hold)
