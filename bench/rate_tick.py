"""Per-tick cost of resolved-rate control: our warm-started OSQP QP beside a plain numpy DLS step and
Pink's ``solve_ik`` (OSQP and DAQP), on the same configurations in the same run.

The ticks come from a ``resolved_rate_dls`` run of a 2 s line on each robot (UR5 and Panda): tick k
gives the configuration ``q_k``, the damping ``lambda_k`` and the twist ``V_k = J_k qd_k`` the
controller realized, so every contender solves the same problem ``min ||J qd - V||^2 +
lambda^2 ||qd||^2`` within the velocity and position-limit bounds. Pink gets the same problem as a
``FrameTask`` whose target is the pose one tick ahead (``FK(q_k + qd_k dt)``) with Tikhonov damping
``lambda^2`` and the same OSQP tolerances; its cost includes its own kinematics (``Configuration``).

A second table sweeps OSQP settings on ticks where one joint is 1 urad from its upper position
limit and moving towards it, so its bound ``(q_max - q)/dt`` is 1e-3 rad/s, the size of OSQP's
default tolerance: iterations, time, how far OSQP's own answer is outside the bounds before our
clipping, and the error against scipy's bounded least squares (BVLS).

Run: ``python -m bench.rate_tick`` (``--quick`` for CI: fewer ticks). Pink and DAQP come with the
``bench`` extra (``pip install -e '.[bench]'``); rows whose package is missing say so.
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear
from scipy.spatial.transform import Rotation

from core.cartesian.rate.control import simulate
from core.cartesian.rate.qp import (
    OSQP_SETTINGS,
    REDUNDANCY_DAMPING,
    RateLimits,
    build_dls_qp,
    damping,
    rate_bounds,
    solve_dls_qp,
)
from core.cartesian.rate.tick_qp import DlsQpSolver
from core.cartesian.task import CartesianTask
from core.kinematics import task_rows


@dataclass(frozen=True)
class Ticks:
    """The per-tick problems of one robot: ``q`` (N, dof), ``qd`` (N, dof), ``lam`` (N,); and the
    mean wall time [us] of one tick of the whole simulated controller on that line."""

    robot: object
    q: np.ndarray
    qd: np.ndarray
    lam: np.ndarray
    dt: float
    controller_tick_us: float


def line_ticks(name: str, count: int) -> Ticks:
    """Ticks of a DLS run along a 2 s line from the robot's home (15 cm and 0.4 rad)."""
    from robots import registry

    robot = registry.get(name)
    T0 = robot.fk(robot.home)
    T_goal = T0.copy()
    T_goal[:3, 3] += [0.15, -0.1, 0.1]
    T_goal[:3, :3] = Rotation.from_rotvec([0.2, 0.1, -0.3]).as_matrix() @ T0[:3, :3]
    task = CartesianTask(robot, robot.home, T_goal, duration=2.0)
    start = time.perf_counter()
    run = simulate(task, "resolved_rate_dls")
    per_tick = (time.perf_counter() - start) / len(run.s) * 1e6
    # Consecutive ticks (warm starts see their real neighbours), from the middle of the line.
    start = max(0, (len(run.sigma) - count) // 2)
    idx = np.arange(start, min(len(run.sigma), start + count))
    return Ticks(robot, run.positions[idx], run.rates[idx], run.damping[idx], run.dt, per_tick)


def _time(fn: Callable[[int], np.ndarray], n: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall time [us] of ``fn(k)`` for each tick and the rates it returned."""
    times, out = np.zeros(n), []
    for k in range(n):
        start = time.perf_counter()
        out.append(fn(k))
        times[k] = (time.perf_counter() - start) * 1e6
    return times, np.array(out)


def contenders(t: Ticks) -> dict[str, Callable[[int], np.ndarray] | str]:
    """Name -> per-tick function (or the reason it is unavailable)."""
    robot, dt = t.robot, t.dt
    rows = task_rows(robot.task_space)
    limits = RateLimits.of(robot)
    J = [robot.jacobian(q)[rows] for q in t.q]
    V = [Jk @ qd for Jk, qd in zip(J, t.qd, strict=True)]
    warm = DlsQpSolver(robot.dof)

    warm_total = DlsQpSolver(robot.dof)
    floor = REDUNDANCY_DAMPING if robot.dof > len(rows) else 0.0

    kinematics_loop, total_loop = robot.fk_jacobian_loop(), robot.fk_jacobian_loop()

    def kinematics(k):
        _, Jk = kinematics_loop(t.q[k])  # pose and Jacobian in one pass, as the controller does
        np.linalg.svd(Jk[rows], compute_uv=False)
        return np.empty(0)

    def ours_total(k):
        _, Jk = total_loop(t.q[k])  # the pose (the controller's error) and the Jacobian
        Jk = Jk[rows]
        lam = damping(np.linalg.svd(Jk, compute_uv=False)[-1], floor=floor)
        lower, upper = rate_bounds(t.q[k], limits, dt)
        return warm_total.step(Jk, V[k], lam, lower, upper).x

    def ours_warm(k):
        lower, upper = rate_bounds(t.q[k], limits, dt)
        return warm.step(J[k], V[k], t.lam[k], lower, upper).x

    def ours_one_shot(solver):
        return lambda k: (
            solve_dls_qp(build_dls_qp(J[k], V[k], t.lam[k], t.q[k], limits, dt), solver).x
        )

    def numpy_dls(k):
        Jk, lam = J[k], t.lam[k]
        qd = Jk.T @ np.linalg.solve(Jk @ Jk.T + lam * lam * np.eye(len(rows)), V[k])
        lower, upper = rate_bounds(t.q[k], limits, dt)
        return np.clip(qd, lower, upper)

    table: dict[str, Callable[[int], np.ndarray] | str] = {
        "kinematics: fk + jacobian + svd": kinematics,
        "ours: kinematics + warm OSQP QP (one tick)": ours_total,
        "ours: warm OSQP QP (build + solve)": ours_warm,
        "ours via qpsolvers, osqp (new workspace per tick)": ours_one_shot("osqp"),
    }
    import qpsolvers

    table["ours via qpsolvers, daqp"] = (
        ours_one_shot("daqp") if "daqp" in qpsolvers.available_solvers else "daqp not installed"
    )
    table["numpy DLS step (bounds by clipping only)"] = numpy_dls
    table.update(pink_contenders(t, V))
    return table


def pink_contenders(t: Ticks, V: list[np.ndarray]) -> dict[str, Callable[[int], np.ndarray] | str]:
    """Pink's ``solve_ik`` with OSQP and DAQP, or why it is unavailable."""
    try:
        import pinocchio as pin
        import qpsolvers
        from pink import Configuration, solve_ik
        from pink.tasks import FrameTask
    except Exception as e:  # not installed, or broken: report, never crash
        reason = f"unavailable ({type(e).__name__}: {e})"
        return {"pink solve_ik, osqp": reason, "pink solve_ik, daqp": reason}
    robot, dt = t.robot, t.dt
    model = robot.model
    targets = [pin.SE3(robot.fk(q + qd * dt)) for q, qd in zip(t.q, t.qd, strict=True)]
    options = {
        "osqp": {"eps_abs": OSQP_SETTINGS["eps_abs"], "eps_rel": OSQP_SETTINGS["eps_rel"]},
        "daqp": {},
    }

    def make(solver):
        if solver not in qpsolvers.available_solvers:
            return f"{solver} not installed"
        task = FrameTask(robot.tip_frame, position_cost=1.0, orientation_cost=1.0)

        def step(k):
            configuration = Configuration(model, pin.Data(model), t.q[k], copy_data=False)
            task.set_target(targets[k])
            damp = max(float(t.lam[k]) ** 2, 1e-12)
            return solve_ik(
                configuration, [task], dt, solver=solver, damping=damp, **options[solver]
            )

        return step

    return {"pink solve_ik, osqp": make("osqp"), "pink solve_ik, daqp": make("daqp")}


def cost_table(t: Ticks) -> list[str]:
    lines = [
        f"### {t.robot.name}: {len(t.q)} ticks of a 2 s line (dt = {t.dt * 1e3:g} ms)",
        "",
        "| per tick | median [us] | p95 [us] | max [us] | max abs(qd - ours) [rad/s] |",
        "|---|---:|---:|---:|---:|",
    ]
    reference = None
    for name, fn in contenders(t).items():
        if isinstance(fn, str):
            lines.append(f"| {name} | {fn} | | | |")
            continue
        fn(0)  # warm caches and imports
        times, rates = _time(fn, len(t.q))
        if name.startswith("ours: warm"):
            reference = rates
        agree = (
            ""
            if reference is None or rates.shape != reference.shape
            else (f"{np.abs(rates - reference).max():.1e}")
        )
        p95 = np.percentile(times, 95)
        lines.append(
            f"| {name} | {np.median(times):.1f} | {p95:.1f} | {times.max():.1f} | {agree} |"
        )
    lines.append(
        f"| whole controller tick (core.cartesian.rate.control.simulate, mean) | "
        f"{t.controller_tick_us:.1f} | | | |"
    )
    return lines


SWEEP = {
    "OSQP defaults (eps 1e-3, check every 25)": {
        "eps_abs": 1e-3, "eps_rel": 1e-3, "check_termination": 25, "adaptive_rho_interval": 0,
    },
    "eps 1e-3, check every iteration": {"eps_abs": 1e-3, "eps_rel": 1e-3},
    "eps 1e-6, check every 25": {"eps_abs": 1e-6, "eps_rel": 1e-6, "check_termination": 25},
    "eps 1e-6, check every iteration": {"eps_abs": 1e-6, "eps_rel": 1e-6},
    "ours: eps 1e-9, check every iteration": {},
    "ours without warm start": {"warm_starting": False},
}  # fmt: skip


def settings_table(t: Ticks) -> list[str]:
    """OSQP settings on ticks with one joint 1 urad short of its upper limit, moving towards it."""
    robot, dt = t.robot, t.dt
    rows = task_rows(robot.task_space)
    base = RateLimits.of(robot)
    problems = []
    for q, qd, lam in zip(t.q, t.qd, t.lam, strict=True):
        j = int(np.argmax(np.abs(qd)))
        position = base.position.copy()
        if qd[j] > 0:
            position[j, 1] = q[j] + 1e-6
        else:
            position[j, 0] = q[j] - 1e-6
        limits = RateLimits(position, base.velocity)
        J = robot.jacobian(q)[rows]
        V = J @ qd
        lower, upper = rate_bounds(q, limits, dt)
        A, b = np.vstack([J, lam * np.eye(robot.dof)]), np.concatenate([V, np.zeros(robot.dof)])
        exact = lsq_linear(A, b, bounds=(lower, upper), method="bvls", tol=1e-14).x
        problems.append((J, V, lam, lower, upper, exact, j))
    lines = [
        f"### {robot.name}: {len(problems)} ticks, one joint's bound (q_max - q)/dt = 1e-3 rad/s",
        "",
        "| OSQP settings | iterations median / max | median [us] | max [us] | "
        "raw overshoot of the bound [rad/s] (share of the bound) | exact fallbacks | "
        "max abs(qd - exact) [rad/s] |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, settings in SWEEP.items():
        solver = DlsQpSolver(robot.dof, **settings)
        its, times, over, err, fallbacks = [], [], 0.0, 0.0, 0
        for J, V, lam, lower, upper, exact, _ in problems:
            step = solver.step(J, V, lam, lower, upper)
            fallbacks += step.fallback
            its.append(step.iterations)
            times.append(step.solve_time * 1e6)
            over = max(over, step.violation)
            err = max(err, float(np.abs(step.x - exact).max()))
        lines.append(
            f"| {name} | {np.median(its):.0f} / {max(its)} | {np.median(times):.1f} | "
            f"{max(times):.1f} | {over:.1e} ({over / 1e-3:.0%}) | {fallbacks} | {err:.1e} |"
        )
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="200 ticks per robot (CI)")
    parser.add_argument("--ticks", type=int, default=1000, help="ticks per robot (default 1000)")
    args = parser.parse_args(argv)
    count = 200 if args.quick else args.ticks
    with warnings.catch_warnings():  # qpsolvers' conversion notes when Pink hands it dense G
        warnings.simplefilter("ignore")
        for name in ("ur5", "panda"):
            ticks = line_ticks(name, count)
            print("\n".join(cost_table(ticks)))
            print()
            print("\n".join(settings_table(ticks)))
            print()


if __name__ == "__main__":
    main()
