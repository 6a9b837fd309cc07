"""I1 (every IK solution of 1,000 random reachable UR5 poses) and I2 (IK along the P3 line, one
configuration branch): ours against EAIK alone and roboticstoolbox's ``ik_LM``.

I1 rows (each call solves the same 1,000 poses, so the time per call in ms is the time per pose in us):
- ours ``Robot.ik_all_many``: every solution within the limits, verified by FK to 1e-9 m / 1e-9 rad,
  deduplicated, labelled, singular check, nearest home first (batched);
- ours ``Robot.ik_all`` pose by pose (what one ``/ik`` request with ``all: true`` runs);
- EAIK alone (batched C++ call, no verification, no limits);
- roboticstoolbox ``ik_LM`` (one solution per pose, C++, the ETS built once, its random restarts),
  on its ``DH.UR5`` with our d1 (checked equal to our FK to 1e-12).

I2 rows: ours ``Robot.ik_many`` (the start's configuration at 200 poses of the P3 line) against the
same walk with our damped Newton from the previous sample (what the sampled method does today).

Run alone: ``python -m bench.ik`` (quick budget). Measured 2026-11-25 on the shared 2-core machine
at load ~8 (single-threaded BLAS): I1 ours batched 195 ms per 1,000 poses (0.84x the toolbox's 233),
ik_all pose by pose 1,456, EAIK alone 20; I2 ik_many 16.8 ms against 50.6 ms for Newton (0.33x).

Not wired into ``python -m bench`` here (``bench/__main__.py`` belongs to another team): add
``"I1", "I2"`` to ``TASKS`` and ``do(ik.i1_all_solutions)``, ``do(ik.i2_line)`` to ``run``.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # as python -m bench does (threaded BLAS thrashes on 2 cores)

import numpy as np  # noqa: E402

from bench.harness import Row, Table, optional  # noqa: E402
from robots import registry  # noqa: E402

POSES = 1000
LINE = 200
Q_START = np.array([0.0, -1.047, 1.571, -2.094, -1.571, 0.0])
Q_GOAL = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
UR5_DH = {  # d, a, alpha of robots/urdf/ur5.urdf
    "d": [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823],
    "a": [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0],
    "alpha": [np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0],
}


def random_poses(robot, n: int = POSES, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    qs = np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, robot.dof))
    return qs, robot.fk_many(qs)


def i1_all_solutions() -> Table:
    robot = registry.get("ur5")
    _, Ts = random_poses(robot)
    found = robot.ik_all_many(Ts, robot.home)
    counts = np.bincount([len(s) for s in found], minlength=9)
    worst = max(float(s.position_errors.max(initial=0)) for s in found)
    rows = [
        Row(
            "ours: ik_all_many (all solutions, verified, batched)",
            lambda: robot.ik_all_many(Ts, robot.home),
            note=f"{sum(len(s) for s in found)} solutions, worst FK error {worst:.0e} m; "
            f"poses with 8/6/4/2: {counts[8]}/{counts[6]}/{counts[4]}/{counts[2]}",
        ),
        Row(
            "ours: ik_all pose by pose (one /ik all:true each)",
            lambda: [robot.ik_all(T, robot.home) for T in Ts],
        ),
        Row(
            "EAIK alone (batched, unverified)",
            lambda: robot.analytic_ik.solve_many(Ts),  # type: ignore[union-attr]
            peer=True,
        ),
    ]
    rows.append(rtb_row(robot, Ts))
    return Table(
        "I1",
        f"Every IK solution of {POSES} random UR5 poses (time per call in ms = per pose in us)",
        "roboticstoolbox ik_LM (one solution, ETS built once)",
        rows,
        unit="ms",
        notes=[
            "Ours returns every solution (up to 8) verified by FK; the toolbox one, unverified."
        ],
    )


def rtb_row(robot, Ts: np.ndarray) -> Row:
    name = "roboticstoolbox ik_LM (one solution, ETS built once)"
    missing = optional("roboticstoolbox")
    if missing:
        return Row(name, unavailable=missing, peer=True)
    import roboticstoolbox as rtb

    links = [
        rtb.RevoluteDH(d=d, a=a, alpha=al, qlim=[-2 * np.pi, 2 * np.pi])
        for d, a, al in zip(UR5_DH["d"], UR5_DH["a"], UR5_DH["alpha"], strict=True)
    ]
    ets = rtb.DHRobot(links, name="UR5").ets()
    err = np.abs(ets.fkine(Q_GOAL).A - robot.fk(Q_GOAL)).max()
    if err > 1e-12:
        raise AssertionError(f"roboticstoolbox's UR5 differs from ours by {err:.3g}")
    solved = [ets.ik_LM(T) for T in Ts]
    ok = sum(bool(s.success) for s in solved)
    return Row(name, lambda: [ets.ik_LM(T) for T in Ts], note=f"{ok}/{len(Ts)} solved", peer=True)


def line_poses(robot, n: int = LINE) -> np.ndarray:
    from scipy.spatial.transform import Rotation, Slerp

    A, B = robot.fk(Q_START), robot.fk(Q_GOAL)
    s = np.linspace(0.0, 1.0, n)
    Ts = np.zeros((n, 4, 4))
    Ts[:, :3, :3] = Slerp([0, 1], Rotation.from_matrix([A[:3, :3], B[:3, :3]]))(s).as_matrix()
    Ts[:, :3, 3] = A[:3, 3] + s[:, None] * (B[:3, 3] - A[:3, 3])
    Ts[:, 3, 3] = 1.0
    return Ts


def i2_line() -> Table:
    robot = registry.get("ur5")
    Ts = line_poses(robot)

    def numeric() -> np.ndarray:
        q, out = Q_START, np.empty((len(Ts), 6))
        for i, T in enumerate(Ts):
            q = out[i] = robot.ik(T, q, position_tolerance=1e-10, orientation_tolerance=1e-10)[0]
        return out

    path = robot.ik_many(Ts, Q_START)
    diff = float(np.abs(path.positions - numeric()).max())
    return Table(
        "I2",
        f"IK along the P3 UR5 line, {LINE} poses, the start's configuration",
        "ours: damped Newton from the previous sample",
        [
            Row(
                "ours: ik_many (analytic, batched)",
                lambda: robot.ik_many(Ts, Q_START),
                note=f"{path.configuration} at every pose; max difference to Newton {diff:.0e} rad",
            ),
            Row("ours: damped Newton from the previous sample", numeric),
        ],
        unit="ms",
    )


if __name__ == "__main__":
    from bench.harness import QUICK, measure

    for make in (i1_all_solutions, i2_line):
        print("\n".join(measure(make(), QUICK).markdown()))
