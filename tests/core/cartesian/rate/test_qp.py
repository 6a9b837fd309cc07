"""The damped least-squares QP of one control tick: formulation, pseudo-inverse equivalence, bounds.

Two formulations that must agree: with lambda = 0 and no active bound the QP step is J^+ V (1e-6
rad/s) on random non-singular configurations of the shipped robots; with active bounds it is the
bounded least-squares solution (scipy's BVLS). Seeded sweeps print the failing input.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from core.cartesian.rate.qp import (
    MAX_DAMPING,
    REDUNDANCY_DAMPING,
    SINGULAR_REGION,
    RateLimits,
    bounded_least_squares,
    build_dls_qp,
    check_solver,
    damping,
    rate_bounds,
    solve_dls_qp,
)
from core.cartesian.rate.tick_qp import DlsQpSolver
from core.errors import InputError
from core.kinematics import task_rows

DT = 1e-3


def _random_problem(robot, rng, min_sigma=SINGULAR_REGION):
    """A configuration away from limits and singularities, and a twist whose J^+ V is well inside
    the velocity limits (so no bound is active)."""
    rows = task_rows(robot.task_space)
    lo, hi = robot.position_limits.T
    while True:
        q = rng.uniform(np.maximum(lo, -np.pi) + 0.05, np.minimum(hi, np.pi) - 0.05)
        J = robot.jacobian(q)[rows]
        if np.linalg.svd(J, compute_uv=False)[-1] >= min_sigma:
            qd = rng.uniform(-0.5, 0.5, robot.dof) * robot.velocity_limits
            return q, J, J @ qd


def test_damping_zero_outside_region_and_smooth_inside():
    assert damping(SINGULAR_REGION) == 0.0 and damping(1.0) == 0.0
    assert damping(0.0) == pytest.approx(MAX_DAMPING)
    sig = np.linspace(0.0, SINGULAR_REGION, 101)
    lam = np.array([damping(x) for x in sig])
    assert np.all(np.diff(lam) <= 0.0)
    assert np.allclose(lam**2, (1.0 - (sig / SINGULAR_REGION) ** 2) * MAX_DAMPING**2)


def test_build_dls_qp_is_the_documented_problem():
    rng = np.random.default_rng(0)
    J, V, q = rng.normal(size=(6, 7)), rng.normal(size=6), rng.uniform(-1, 1, 7)
    limits = RateLimits(np.tile([-1.5, 1.5], (7, 1)), np.full(7, 2.0))
    problem = build_dls_qp(J, V, 0.3, q, limits, DT)
    assert np.allclose(problem.P, J.T @ J + 0.09 * np.eye(7))
    assert np.allclose(problem.q, -J.T @ V)
    lower, upper = rate_bounds(q, limits, DT)
    assert np.array_equal(problem.lb, lower) and np.array_equal(problem.ub, upper)
    assert np.allclose(lower, np.maximum(-2.0, (-1.5 - q) / DT))
    assert np.allclose(upper, np.minimum(2.0, (1.5 - q) / DT))


def test_rate_bounds_never_empty_outside_limits():
    limits = RateLimits(np.array([[-1.0, 1.0]] * 2), np.array([2.0, 2.0]))
    lower, upper = rate_bounds(np.array([1.5, -1.5]), limits, DT)
    assert np.all(lower <= upper)
    assert lower[0] == upper[0] == -2.0 and lower[1] == upper[1] == 2.0


@pytest.mark.parametrize("name", ["planar_2r", "puma560", "ur5"])
def test_undamped_qp_step_equals_pseudo_inverse(name):
    registry = pytest.importorskip("robots.registry")
    robot = registry.get(name)
    limits = RateLimits.of(robot)._replace(acceleration=None)  # (the position bound of a tick)
    rng = np.random.default_rng(7)
    solver = DlsQpSolver(robot.dof)  # one warm-started workspace across unrelated problems
    for trial in range(60):
        q, J, V = _random_problem(robot, rng)
        lower, upper = rate_bounds(q, limits, DT)
        expected = np.linalg.pinv(J) @ V
        assert np.all((expected > lower) & (expected < upper))
        step = solver.step(J, V, 0.0, lower, upper)
        one_shot = solve_dls_qp(build_dls_qp(J, V, 0.0, q, limits, DT), "osqp")
        for got in (step.x, one_shot.x):
            err = np.abs(got - expected).max()
            assert err <= 1e-6, f"{name} trial {trial}: q={q.tolist()} V={V.tolist()} err={err:.2e}"
        assert step.found and one_shot.found


@pytest.mark.parametrize("seed", range(8))
def test_active_bounds_give_bounded_least_squares_exactly_inside(seed):
    rng = np.random.default_rng(seed)
    dof = 6 + seed % 2
    J, V = rng.normal(size=(6, dof)), 5.0 * rng.normal(size=6)
    pos = np.tile([-2.0, 2.0], (dof, 1))
    q = rng.uniform(-2.0, 2.0, dof)
    q[0] = 2.0 - 1e-6  # one joint 1 um from its upper limit: bound of order OSQP's default eps
    limits = RateLimits(pos, np.full(dof, 1.0))
    lam = 0.05
    lower, upper = rate_bounds(q, limits, DT)
    A, b = np.vstack([J, lam * np.eye(dof)]), np.concatenate([V, np.zeros(dof)])
    expected = lsq_linear(A, b, bounds=(lower, upper), method="bvls", tol=1e-14).x
    assert np.any((expected <= lower + 1e-12) | (expected >= upper - 1e-12)), "no active bound"
    for solver in (DlsQpSolver(dof), DlsQpSolver(dof, eps_abs=1e-3, eps_rel=1e-3)):
        step = solver.step(J, V, lam, lower, upper)
        assert np.all(step.x >= lower) and np.all(step.x <= upper)  # exactly: clipped
    tight = DlsQpSolver(dof).step(J, V, lam, lower, upper)
    assert np.abs(tight.x - expected).max() <= 1e-6, f"seed {seed}: {tight.x} vs {expected}"


def test_redundant_arm_against_a_limit_is_solved_exactly():
    """ADMM is slow on this ill-conditioned QP (Panda, damping floor, a joint 1 urad from its
    limit and pushed into it): OSQP stops at max_iter and the exact fallback answers."""
    registry = pytest.importorskip("robots.registry")
    robot = registry.get("panda")
    base = RateLimits.of(robot)
    solver = DlsQpSolver(robot.dof)
    rng = np.random.default_rng(5)
    fallbacks = 0
    for _ in range(20):
        q = robot.home + rng.normal(scale=0.05, size=robot.dof)
        qd = rng.uniform(-1, 1, robot.dof)
        j = int(np.argmax(np.abs(qd)))
        position = base.position.copy()
        position[j, int(qd[j] > 0)] = q[j] + np.sign(qd[j]) * 1e-6
        limits = RateLimits(position, base.velocity)
        J = robot.jacobian(q)
        lower, upper = rate_bounds(q, limits, DT)
        step = solver.step(J, J @ qd, REDUNDANCY_DAMPING, lower, upper)
        exact = bounded_least_squares(J, J @ qd, REDUNDANCY_DAMPING, lower, upper)
        assert np.all(step.x >= lower) and np.all(step.x <= upper)
        assert np.abs(step.x - exact).max() <= 1e-5
        assert abs(step.x[j]) <= 1e-3 * (1 + 1e-9)  # the position bound, not the speed limit
        fallbacks += step.fallback
    assert fallbacks < 20


def test_public_api_path_matches_extension_path():
    rng = np.random.default_rng(3)
    J, V = rng.normal(size=(6, 6)), rng.normal(size=6)
    lower, upper = -np.ones(6), np.ones(6)
    fast, slow = DlsQpSolver(6), DlsQpSolver(6)
    slow._ext = None
    for _ in range(3):
        a, b = fast.step(J, V, 0.01, lower, upper), slow.step(J, V, 0.01, lower, upper)
        assert np.allclose(a.x, b.x, atol=1e-9)
        assert a.iterations == b.iterations


def test_solver_name_is_checked_against_installed_solvers():
    assert check_solver("osqp") == "osqp"
    with pytest.raises(InputError) as info:
        check_solver("no_such_solver")
    assert info.value.field == ("solver",)
    assert "osqp" in info.value.extra["available"]


@pytest.mark.parametrize("solver", ["daqp", "quadprog", "proxqp", "clarabel"])
def test_other_installed_solvers_agree(solver):
    import qpsolvers

    if solver not in qpsolvers.available_solvers:
        pytest.skip(f"{solver} is not installed")
    rng = np.random.default_rng(11)
    J, V, q = rng.normal(size=(6, 7)), 3.0 * rng.normal(size=6), rng.uniform(-1, 1, 7)
    limits = RateLimits(np.tile([-1.5, 1.5], (7, 1)), np.full(7, 1.0))
    problem = build_dls_qp(J, V, 0.05, q, limits, DT)
    ours = solve_dls_qp(problem, "osqp").x
    theirs = solve_dls_qp(problem, solver).x
    assert np.abs(ours - theirs).max() <= 1e-6


def test_benchmark_runs_quickly(capsys):
    pytest.importorskip("robots.registry")
    from bench import rate_tick

    rate_tick.main(["--ticks", "10"])
    out = capsys.readouterr().out
    for row in ("ours: warm OSQP QP", "numpy DLS step", "pink solve_ik, osqp", "OSQP defaults"):
        assert row in out
