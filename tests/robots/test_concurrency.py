"""Kinematics from 8 threads at once agree with serial results (a fresh pinocchio Data per call)."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from robots import registry


def work(args):
    name, qs = args
    robot = registry.get(name)
    fk = np.array([robot.fk(q) for q in qs])
    jac = np.array([robot.jacobian(q) for q in qs])
    ik = np.array([robot.ik(T, q + 0.05).positions for T, q in zip(fk, qs, strict=True)])
    # every solution (EAIK, with the Panda's held-joint solver cache shared between threads)
    every = [robot.ik_all(T, q + 0.05) for T, q in zip(fk[:10], qs[:10], strict=True)]
    solutions = np.concatenate([s.positions for s in every])
    labels = np.array([str(c) for s in every for c in s.configurations])
    return fk, jac, ik, robot.fk_many(qs), solutions, labels


def test_eight_threads_agree_with_serial() -> None:
    rng = np.random.default_rng(0)
    tasks = []
    for k in range(32):
        name = registry.names()[k % 4]
        robot = registry.get(name)
        lo, hi = robot.position_limits.T
        tasks.append((name, rng.uniform(lo + 0.1, hi - 0.1, (40, robot.dof))))
    serial = [work(t) for t in tasks]
    with ThreadPoolExecutor(max_workers=8) as pool:
        parallel = list(pool.map(work, tasks))
    for s, p in zip(serial, parallel, strict=True):
        for a, b in zip(s, p, strict=True):
            np.testing.assert_array_equal(a, b)


def test_registry_get_from_many_threads_returns_one_robot() -> None:
    with ThreadPoolExecutor(max_workers=8) as pool:
        got = list(pool.map(lambda _: registry.get("panda"), range(64)))
    assert all(r is got[0] for r in got)
