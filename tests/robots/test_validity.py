"""``robots.validity.GroupedClearance`` against the checker it groups: each group's distance is the
smallest of its pairs' (the numpy closed forms), its motion weights bound how fast that minimum
changes, its close pairs give the minimum's gradient (finite differences), ``collides`` agrees
with the distances and the margin, and ``closest_pair`` names a real pair."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bench import mbm
from core.motion.clearance import GroupClearance
from robots import registry
from robots.collision import CollisionChecker, Obstacle, robot_setup
from robots.validity import GroupedClearance
from service.convert.environment import collision_check
from service.schemas.environment import Environment


def T(p, rpy=(0.3, 0.2, 0.1)) -> np.ndarray:
    M = np.eye(4)
    M[:3, :3] = pin.rpy.rpyToMatrix(*rpy)
    M[:3, 3] = p
    return M


def ur5_checker(clearance: float = 0.02) -> CollisionChecker:
    robot = registry.get("ur5")
    geometry, allowed = robot_setup(robot)
    obstacles = [
        Obstacle("box", "box", size=(0.3, 0.2, 0.1), T_base_obstacle=T([0.4, 0.2, 0.3])),
        Obstacle("ball", "sphere", radius=0.1, T_base_obstacle=T([0.3, -0.3, 0.5])),
        Obstacle("can", "cylinder", radius=0.05, length=0.4, T_base_obstacle=T([-0.3, 0.3, 0.4])),
        Obstacle("rod", "capsule", radius=0.05, length=0.4, T_base_obstacle=T([-0.3, -0.3, 0.4])),
        Obstacle("floor", "halfspace", normal=(0.0, 0.0, 1.0), offset=-0.05),
    ]
    return CollisionChecker(robot, geometry, obstacles, clearance=clearance, allowed_self=allowed)


def panda_checker() -> CollisionChecker:
    problem = mbm.problems(1, ("box",))[0]
    robot = registry.resolve(mbm.robot())
    env = Environment.model_validate(mbm.environment(problem))
    check = collision_check(robot, env, mbm.urdf())
    assert check is not None
    return check


CHECKERS = {"ur5": ur5_checker, "mbm_panda": panda_checker}


def members(group: GroupedClearance, check: CollisionChecker) -> list[np.ndarray]:
    """The checker's pairs of each group, by the grouping rule (a link against the obstacles or
    against the other links)."""
    links = set(check.robot.frame_names())
    keys = [(a, "links" if b in links else "obstacles") for a, b in check.pair_names]
    return [np.array([p for p, k in enumerate(keys) if k == g]) for g in group.pair_names]


def configurations(check: CollisionChecker, n: int, seed: int) -> np.ndarray:
    lim = check.robot.position_limits
    lo, hi = np.maximum(lim[:, 0], -np.pi), np.minimum(lim[:, 1], np.pi)
    return np.random.default_rng(seed).uniform(lo, hi, (n, check.robot.dof))


@pytest.mark.parametrize("name", sorted(CHECKERS))
def test_group_minima_are_the_checkers_minima(name: str) -> None:
    check = CHECKERS[name]()
    group = GroupedClearance(check)
    assert isinstance(group, GroupClearance)
    qs = configurations(check, 60, 1)
    D, G = check.distances(qs), group.distances(qs)
    for g, idx in enumerate(members(group, check)):
        expected = D[:, idx].min(axis=1)
        outside = (expected > 0) | (G[:, g] > 0)  # coal's penetration is not a signed distance
        np.testing.assert_allclose(G[outside, g], expected[outside], atol=1e-5)
        assert np.all((G[:, g] < 0) == (expected < 0) | ~outside)
        assert group.threshold[g] == pytest.approx(check.threshold[idx].max())
        np.testing.assert_array_equal(
            group.motion_weights[g], check.motion_weights[idx].max(axis=0)
        )
    q = qs[0]
    chosen = np.array([len(group.threshold) - 1, 0])
    np.testing.assert_allclose(group.pair_distances(q, chosen), G[0, chosen], atol=1e-12)


@pytest.mark.parametrize("name", sorted(CHECKERS))
def test_motion_weights_bound_the_group_distance(name: str) -> None:
    check = CHECKERS[name]()
    group = GroupedClearance(check)
    rng = np.random.default_rng(2)
    qs = configurations(check, 40, 3)
    steps = rng.normal(0.0, 0.05, qs.shape)
    change = np.abs(group.distances(qs + steps) - group.distances(qs))
    bound = np.abs(steps) @ group.motion_weights.T
    assert np.all(change <= bound + 1e-6)


@pytest.mark.parametrize("name", sorted(CHECKERS))
def test_collides_agrees_with_the_distances(name: str) -> None:
    check = CHECKERS[name]()
    group = GroupedClearance(check)
    qs = configurations(check, 80, 4)
    margin = 0.01
    slack = group.distances(qs) - group.threshold - margin
    decided = np.abs(slack).min(axis=1) > 1e-5
    for q, s, ok in zip(qs, slack, decided, strict=True):
        if ok:
            assert group.collides(q, margin) == bool((s < 0).any())


def test_close_pairs_give_the_gradient_of_the_group_minimum() -> None:
    check = ur5_checker()
    group = GroupedClearance(check)
    h = 1e-6
    checked = 0
    for q in configurations(check, 30, 5):
        pairs, d, n, Jp = group.close_pairs(q, 0.3)
        for k, g in enumerate(pairs):
            if d[k] <= 1e-3:
                continue
            grad = n[k] @ Jp[k]
            fd = np.array([
                (group.pair_distances(q + h * e, np.array([g]))[0]
                 - group.pair_distances(q - h * e, np.array([g]))[0]) / (2 * h)
                for e in np.eye(len(q))
            ])  # fmt: skip
            if np.abs(fd - grad).max() < 1e-4 * max(1.0, np.abs(grad).max()):
                checked += 1
            else:  # the minimum switched pairs within h: a kink, not an error of the gradient
                assert np.abs(fd).max() <= np.abs(group.motion_weights[g]).sum() + 1e-6
    assert checked > 20


def test_closest_pair_names_a_real_pair() -> None:
    check = ur5_checker()
    group = GroupedClearance(check)
    for q in configurations(check, 10, 6):
        names, d, thr = group.closest_pair(q)
        D = check.distances(q[None])[0]
        p = [k for k, n in enumerate(check.pair_names) if n == names]
        assert p
        if d > 0:
            assert min(abs(D[k] - d) for k in p) < 1e-5
            assert (D - check.threshold).min() == pytest.approx(d - thr, abs=1e-5)
