"""IK round-trips from random reachable poses, closed-form planar IK, and honest failure reports."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from core.geometry.so3 import rotation_angle
from robots import ik as robot_ik
from robots import registry
from tests.robots.inline_urdfs import PLANAR_3R_URDF

SPATIAL = ["puma560", "ur5", "panda"]


def residuals(robot, q: np.ndarray, T_goal: np.ndarray) -> tuple[float, float]:
    """Position [m] and orientation [rad] error of FK(q) against the goal, in the robot's task."""
    T = robot.fk(q)
    if robot.task_space == "position_xy":
        return float(np.linalg.norm(T[:2, 3] - T_goal[:2, 3])), 0.0
    return float(np.linalg.norm(T[:3, 3] - T_goal[:3, 3])), float(
        rotation_angle(T[:3, :3].T @ T_goal[:3, :3])
    )


def check_honest(robot, result, T_goal: np.ndarray) -> None:
    pe, oe = residuals(robot, result.positions, T_goal)
    assert result.position_error == pytest.approx(pe, abs=1e-9)
    assert result.orientation_error == pytest.approx(oe, abs=1e-8)
    lo, hi = robot.position_limits.T
    inside = bool(np.all(result.positions >= lo - 1e-12) and np.all(result.positions <= hi + 1e-12))
    assert result.within_limits == inside
    assert result.success == (pe <= 1e-6 and oe <= 1e-6 and inside)


@pytest.mark.parametrize("name", [*SPATIAL, "planar_2r"])
def test_round_trip_from_seeds_within_0_3_rad(name: str) -> None:
    robot = registry.get(name)
    lo, hi = robot.position_limits.T
    rng = np.random.default_rng(42)
    n, ok, failures = 1000, 0, []
    for _ in range(n):
        q_true = rng.uniform(lo, hi)
        seed = np.clip(q_true + rng.uniform(-0.3, 0.3, robot.dof), lo, hi)
        T = robot.fk(q_true)
        result = robot.ik(T, seed)
        check_honest(robot, result, T)
        ok += result.success
        if not result.success:
            failures.append(q_true.tolist())
    assert ok / n >= 0.99, f"{name}: {ok}/{n} succeeded; first failures at q_true={failures[:3]}"


@pytest.mark.parametrize("name", SPATIAL)
def test_unreachable_pose_fails_honestly(name: str) -> None:
    robot = registry.get(name)
    T = robot.fk(robot.home)
    T[:3, 3] = [3.0, 0.5, 0.2]  # beyond every arm's reach
    result = robot.ik(T, robot.home, max_iterations=30)
    assert not result.success and result.iterations <= 30
    assert result.position_error > 1.0
    check_honest(robot, result, T)


def test_iteration_cap_and_limits_are_respected() -> None:
    panda = registry.get("panda")
    lo, hi = panda.position_limits.T
    rng = np.random.default_rng(3)
    for _ in range(50):
        T = panda.fk(rng.uniform(lo, hi))
        result = panda.ik(T, rng.uniform(lo, hi), max_iterations=5)
        assert result.iterations <= 5
        assert np.all(result.positions >= lo) and np.all(result.positions <= hi)
        check_honest(panda, result, T)


def test_planar_closed_form_both_branches_nearest_seed() -> None:
    robot = registry.get("planar_2r")
    q_up = np.array([0.3, 1.1])
    T = robot.fk(q_up)
    # the mirror branch: q2 -> -q2, q1 -> q1 + 2 atan2(l2 sin q2, l1 + l2 cos q2)
    q_down = np.array([0.3 + 2 * math.atan2(0.8 * math.sin(1.1), 1.0 + 0.8 * math.cos(1.1)), -1.1])
    np.testing.assert_allclose(robot.fk(q_down)[:2, 3], T[:2, 3], atol=1e-12)
    for seed, expected in ((q_up + 0.2, q_up), (q_down - 0.2, q_down)):
        result = robot.ik(T, seed)
        assert result.success and result.iterations == 1
        np.testing.assert_allclose(result.positions, expected, atol=1e-12)
        assert result.position_error <= 1e-12 and result.orientation_error == 0.0


def test_planar_only_x_and_y_count() -> None:
    robot = registry.get("planar_2r")
    T = np.eye(4)
    T[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # any orientation, any z
    T[:3, 3] = [0.9, -0.7, 5.0]
    result = robot.ik(T, np.zeros(2))
    assert result.success
    np.testing.assert_allclose(robot.fk(result.positions)[:2, 3], [0.9, -0.7], atol=1e-12)


@pytest.mark.parametrize("r", [0.1, 1.9, 3.0])
def test_planar_outside_the_annulus_reports_the_distance(r: float) -> None:
    robot = registry.get("planar_2r")
    T = np.eye(4)
    T[:2, 3] = r * np.array([math.cos(0.7), math.sin(0.7)])
    result = robot.ik(T, np.zeros(2))
    assert not result.success
    expected = 0.2 - r if r < 0.2 else r - 1.8
    assert result.position_error == pytest.approx(expected, abs=1e-12)
    check_honest(robot, result, T)


def test_planar_seed_near_the_pi_limit_wraps_inside() -> None:
    robot = registry.get("planar_2r")
    q = np.array([-3.1, 0.5])
    result = robot.ik(robot.fk(q), np.array([3.1, 0.5]))
    assert result.success and result.within_limits
    assert abs(result.positions[0]) <= math.pi


def test_numeric_position_xy_ik_for_an_inline_planar_arm() -> None:
    robot = registry.load_inline(PLANAR_3R_URDF, "tip", "base")
    assert robot.task_space == "position_xy" and robot.dof == 3
    rng = np.random.default_rng(5)
    lo, hi = robot.position_limits.T
    ok = 0
    for _ in range(200):
        q = rng.uniform(lo, hi)
        T = robot.fk(q)
        result = robot.ik(T, np.clip(q + rng.uniform(-0.3, 0.3, 3), lo, hi))
        check_honest(robot, result, T)
        ok += result.success
    assert ok >= 198


def test_search_without_seed_finds_far_solutions() -> None:
    for name in SPATIAL:
        robot = registry.get(name)
        lo, hi = robot.position_limits.T
        rng = np.random.default_rng(7)
        found = 0
        for _ in range(20):
            T = robot.fk(rng.uniform(np.maximum(lo, -2.5), np.minimum(hi, 2.5)))
            found += robot_ik.search(robot, T).success
        assert found >= 19, name


def test_ik_is_fast_when_the_seed_is_close() -> None:
    """Per-sample IK along a line: a seed 1 mrad away converges in a couple of iterations."""
    robot = registry.get("ur5")
    q = robot.home
    T = robot.fk(q + 1e-3)
    robot.ik(T, q)
    start = time.perf_counter()
    for _ in range(200):
        result = robot.ik(T, q)
    per_call = (time.perf_counter() - start) / 200
    assert result.success and result.iterations <= 3
    assert per_call < 2e-3  # ~0.1 ms on a laptop; generous for slow CI machines
