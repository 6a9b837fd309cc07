"""P5: one resolved-rate tick (kinematics + QP) on the UR5 and the Panda, and a 1,000-tick run.

The per-tick rows are ``bench.rate_tick``'s contenders (the rate-control engineer's benchmark, which
``python -m bench.rate_tick`` still runs on its own with its OSQP settings sweep): consecutive ticks
of a ``resolved_rate_dls`` run, each row solving the same problems ``min ||J qd - V||^2 +
lambda^2 ||qd||^2`` within the joint velocity and position-limit bounds. Here each row walks through
the ticks in order (so warm starts see their real neighbours) inside the suite's alternating rounds.

The 1,000-tick run: a 1 s line at ``dt`` = 1 ms from the robot's home (15 cm and 0.4 rad, as in
``rate_tick.line_ticks``). Ours: the controller loop alone (``core.cartesian.rate.control.simulate``), the whole
core call (``plan``: controller, output sampling, dense checks) and the HTTP round trip. Pink: its
closed loop (``solve_ik`` with a ``FrameTask`` whose target is our run's pose one tick ahead, then
``Configuration.integrate_inplace``). numpy: 1,000 DLS steps with pinocchio kinematics.

``python -m bench.rate [--repeats N]``: the run side by side with the Pink + DAQP loop alone,
interleaved (ours, plan, Pink in turn, N rounds), medians of process CPU time and of wall time, and
their ratios: on a shared, loaded machine CPU time is the steadier figure.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import time
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from bench.harness import Row, Table, http_row, optional
from bench.rate_tick import contenders, line_ticks
from core.cartesian.plan import plan
from core.cartesian.rate.control import simulate
from core.cartesian.rate.qp import OSQP_SETTINGS, RateLimits, rate_bounds
from core.cartesian.task import CartesianTask
from core.kinematics import task_rows
from robots import registry

REFERENCE = "ours: kinematics + warm OSQP QP (one tick)"
RUN_TICKS = 1000


def _cycling(fn, count: int):
    ticks = itertools.cycle(range(count))
    return lambda: fn(next(ticks))


def p5_tick(name: str, count: int) -> Table:
    ticks = line_ticks(name, count)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = contenders(ticks)
    for label, fn in table.items():
        peer = "pink" in label or "qpsolvers" in label
        if isinstance(fn, str):
            rows.append(Row(label, unavailable=fn, peer=peer))
        else:
            rows.append(Row(label, _cycling(fn, len(ticks.q)), peer=peer))
    return Table(
        "P5",
        f"one resolved-rate tick, {ticks.robot.name}, {len(ticks.q)} consecutive ticks, "
        f"dt = {ticks.dt * 1e3:g} ms, velocity and position limits",
        REFERENCE,
        rows,
        notes=[
            "Pink rows include Pink's own kinematics (`Configuration`) and a new QP workspace per "
            "call (qpsolvers); ours keeps one OSQP workspace per run, updates it in place and "
            "warm-starts it. Whole simulated controller tick (pose error, path clock, "
            f"bookkeeping), mean: {ticks.controller_tick_us:.0f} us.",
        ],
    )


def run_task(name: str) -> CartesianTask:
    robot = registry.get(name)
    T0 = robot.fk(robot.home)
    T_goal = T0.copy()
    T_goal[:3, 3] += [0.15, -0.1, 0.1]
    T_goal[:3, :3] = Rotation.from_rotvec([0.2, 0.1, -0.3]).as_matrix() @ T0[:3, :3]
    return CartesianTask(robot, robot.home, T_goal, duration=RUN_TICKS * 1e-3)


def p5_run(name: str, client=None, url: str = "") -> Table:
    task = run_task(name)
    robot = task.robot
    run = simulate(task, "resolved_rate_dls")
    rows = [
        Row("ours: core simulate, resolved_rate_dls", lambda: simulate(task, "resolved_rate_dls"),
            note=f"{len(run.damping)} ticks"),
        Row("ours: core plan (controller + output + dense checks)",
            lambda: plan(task, "resolved_rate_dls")),
    ]  # fmt: skip
    if client is not None:
        T = task.T_goal
        body = {
            "robot": name,
            "method": "resolved_rate_dls",
            "start": {"positions": robot.home.tolist()},
            "goal": {
                "pose": {
                    "position": T[:3, 3].tolist(),
                    "orientation": Rotation.from_matrix(T[:3, :3]).as_quat().tolist(),
                }
            },
            "duration": RUN_TICKS * 1e-3,
        }
        rows.append(
            http_row(
                client, url, "/v1/trajectories/cartesian", body, "ours: HTTP resolved_rate_dls"
            )
        )
    rows.append(Row("numpy DLS loop (pinocchio kinematics, clipping)", numpy_loop(task, run)))
    rows += pink_loops(task, run)
    return Table(
        "P5",
        f"{RUN_TICKS:,}-tick resolved-rate run, {name}, 1 s line at dt = 1 ms",
        "ours: core simulate, resolved_rate_dls",
        rows,
        unit="ms",
    )


def numpy_loop(task: CartesianTask, run):
    robot, rows = task.robot, task_rows(task.robot.task_space)
    limits, dt = RateLimits.of(robot), run.dt
    ticks = min(len(run.damping), len(run.rates))
    V = [
        robot.jacobian(q)[rows] @ qd
        for q, qd in zip(run.positions[:ticks], run.rates[:ticks], strict=True)
    ]
    eye = np.eye(len(rows))

    def loop() -> np.ndarray:
        q = np.array(robot.home, dtype=float)
        for k in range(ticks):
            robot.fk(q)
            J = robot.jacobian(q)[rows]
            lam = float(run.damping[k])
            qd = J.T @ np.linalg.solve(J @ J.T + lam * lam * eye, V[k])
            lower, upper = rate_bounds(q, limits, dt)
            q = q + np.clip(qd, lower, upper) * dt
        return q

    return loop


def pink_loops(task: CartesianTask, run) -> list[Row]:
    names = ("pink solve_ik loop, osqp", "pink solve_ik loop, daqp")
    missing = optional("pink")
    if missing:
        return [Row(n, unavailable=missing, peer=True) for n in names]
    import pinocchio as pin
    import qpsolvers
    from pink import Configuration, solve_ik
    from pink.tasks import FrameTask

    robot, dt = task.robot, run.dt
    model = robot.model
    ticks = len(run.damping)
    targets = [
        pin.SE3(robot.fk(q + qd * dt))
        for q, qd in zip(run.positions[:ticks], run.rates[:ticks], strict=True)
    ]
    damp = [max(float(lam) ** 2, 1e-12) for lam in run.damping]
    options = {"osqp": {"eps_abs": OSQP_SETTINGS["eps_abs"], "eps_rel": OSQP_SETTINGS["eps_rel"]}}

    def make(solver: str):
        if solver not in qpsolvers.available_solvers:
            return None
        frame_task = FrameTask(robot.tip_frame, position_cost=1.0, orientation_cost=1.0)

        def loop() -> np.ndarray:
            configuration = Configuration(model, pin.Data(model), np.array(robot.home))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                for k, target in enumerate(targets):
                    frame_task.set_target(target)
                    v = solve_ik(
                        configuration, [frame_task], dt, solver=solver, damping=damp[k],
                        **options.get(solver, {}),
                    )  # fmt: skip
                    configuration.integrate_inplace(v, dt)
            return configuration.q

        return loop

    out = []
    for n, solver in zip(names, ("osqp", "daqp"), strict=True):
        fn = make(solver)
        out.append(Row(n, fn, unavailable="" if fn else f"{solver} not installed", peer=True))
    return out


def side_by_side(name: str, repeats: int) -> str:
    """One line: medians of CPU and wall time [ms] of our run, our plan and the Pink + DAQP loop
    over ``repeats`` interleaved rounds, and the ratios to Pink."""
    task = run_task(name)
    run = simulate(task, "resolved_rate_dls")
    pink = next(r for r in pink_loops(task, run) if r.name.endswith("daqp"))
    if pink.fn is None:
        return f"{name}: pink + daqp unavailable ({pink.unavailable})"
    fns = {
        "simulate": lambda: simulate(task, "resolved_rate_dls"),
        "plan": lambda: plan(task, "resolved_rate_dls"),
        "pink": pink.fn,
    }
    cpu: dict[str, list[float]] = {k: [] for k in fns}
    wall: dict[str, list[float]] = {k: [] for k in fns}
    for fn in fns.values():
        fn()  # warm-up
    for _ in range(repeats):
        for key, fn in fns.items():
            w, c = time.perf_counter(), time.process_time()
            fn()
            cpu[key].append(time.process_time() - c)
            wall[key].append(time.perf_counter() - w)
    c = {k: statistics.median(v) * 1e3 for k, v in cpu.items()}
    w = {k: statistics.median(v) * 1e3 for k, v in wall.items()}
    return (
        f"{name}: CPU ms simulate {c['simulate']:.1f}, plan {c['plan']:.1f}, pink+daqp "
        f"{c['pink']:.1f}: simulate/pink {c['simulate'] / c['pink']:.2f}x, plan/pink "
        f"{c['plan'] / c['pink']:.2f}x | wall ms {w['simulate']:.1f}, {w['plan']:.1f}, "
        f"{w['pink']:.1f}: {w['simulate'] / w['pink']:.2f}x, {w['plan'] / w['pink']:.2f}x"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="P5 run: ours beside the Pink + DAQP loop")
    parser.add_argument("--repeats", type=int, default=9, help="interleaved rounds (default 9)")
    args = parser.parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in ("ur5", "panda"):
            print(side_by_side(name, args.repeats))


if __name__ == "__main__":
    main()
