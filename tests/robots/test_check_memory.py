"""One continuous check never allocates more than ``CHECK_WORKING_BYTES`` beyond its inputs, whatever
the points x pairs (measured with tracemalloc: Python's and numpy's allocations)."""

from __future__ import annotations

import tracemalloc

import numpy as np

from robots import registry
from robots.collision import CHECK_WORKING_BYTES, CollisionChecker, Obstacle, robot_setup


def peak_bytes(check: CollisionChecker, times: np.ndarray, qs: np.ndarray) -> tuple[int, object]:
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        result = check.check_path(times, qs)
        return tracemalloc.get_traced_memory()[1] - base, result
    finally:
        tracemalloc.stop()


def test_a_30000_sample_turn_against_256_obstacles_stays_within_the_bound() -> None:
    """The UR5 turning its base a full turn in 30,000 samples past 256 obstacles of every shape
    (1,806 pairs): it took 504 MiB."""
    robot = registry.get("ur5")
    geometry, allowed = robot_setup(robot)
    rng = np.random.default_rng(0)
    obstacles = []
    for k in range(256):
        T = np.eye(4)
        angle = 2 * np.pi * k / 256
        T[:3, 3] = [1.5 * np.cos(angle), 1.5 * np.sin(angle), rng.uniform(0.0, 0.8)]
        shape = ("box", "sphere", "cylinder", "capsule")[k % 4]
        obstacles.append(Obstacle(f"o{k}", shape, size=(0.1, 0.1, 0.1), radius=0.05, length=0.1,
                                  T_base_obstacle=T))  # fmt: skip
    check = CollisionChecker(robot, geometry, obstacles, allowed_self=allowed)
    n = 30_000
    qs = np.linspace(robot.home, robot.home + np.array([2 * np.pi, 0, 0, 0, 0, 0]), n)
    peak, result = peak_bytes(check, np.linspace(0.0, 30.0, n), qs)
    assert check.n_pairs == 1806
    assert result.contact is None  # type: ignore[attr-defined]
    assert peak <= CHECK_WORKING_BYTES, peak / 2**20


def test_a_distance_that_stays_flat_refines_deep_within_the_bound() -> None:
    """An obstacle coaxial with the base while the arm turns about it: the closest pair's distance
    is constant while its motion bound is not, so certifying it cuts the whole turn into pieces of
    2e-4 m of motion, depth first, within the same bound; the certified value is the true one."""
    robot = registry.get("ur5")
    geometry, _ = robot_setup(robot)
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.0, 1.2]  # above the arm, on the base's axis
    check = CollisionChecker(robot, geometry, [Obstacle("disc", "cylinder", radius=0.3,
                             length=0.05, T_base_obstacle=T)], self_collision=False)  # fmt: skip
    qs = np.linspace(robot.home, robot.home + np.array([2 * np.pi, 0, 0, 0, 0, 0]), 200)
    peak, result = peak_bytes(check, np.linspace(0.0, 10.0, 200), qs)
    exact = check.distances(qs).min()
    assert abs(check.distances(qs).min(axis=1) - exact).max() < 1e-9  # flat indeed
    assert exact - 1e-4 <= result.min_clearance <= exact  # type: ignore[attr-defined]
    assert result.evaluations > 10_000  # type: ignore[attr-defined]
    assert peak <= CHECK_WORKING_BYTES, peak / 2**20
