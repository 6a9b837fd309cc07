"""The shipped URDFs equal an independent Denavit-Hartenberg implementation (issue 3's tables)."""

from __future__ import annotations

import math
import re
from importlib import resources

import numpy as np
import pytest

from robots import registry

PI = math.pi
DEG = PI / 180


def rot_x(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    T = np.zeros((*np.shape(a), 4, 4))
    T[..., 0, 0] = 1
    T[..., 1, 1], T[..., 1, 2], T[..., 2, 1], T[..., 2, 2] = c, -s, s, c
    T[..., 3, 3] = 1
    return T


def rot_z(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    T = np.zeros((*np.shape(a), 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 1, 0], T[..., 1, 1] = c, -s, s, c
    T[..., 2, 2] = T[..., 3, 3] = 1
    return T


def trans(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = x, y, z
    return T


def standard_dh(q: np.ndarray, d, a, alpha) -> np.ndarray:
    """Prod_i Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i), q (N, n) -> (N, 4, 4)."""
    T = np.broadcast_to(np.eye(4), (q.shape[0], 4, 4))
    for i in range(q.shape[1]):
        T = T @ rot_z(q[:, i]) @ trans(0, 0, d[i]) @ trans(a[i], 0, 0) @ rot_x(np.float64(alpha[i]))
    return T


def modified_dh(q: np.ndarray, a, d, alpha, flange: float) -> np.ndarray:
    """Prod_i Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i), then Tz(flange) (Craig's convention)."""
    T = np.broadcast_to(np.eye(4), (q.shape[0], 4, 4))
    for i in range(q.shape[1]):
        T = T @ rot_x(np.float64(alpha[i])) @ trans(a[i], 0, 0) @ rot_z(q[:, i]) @ trans(0, 0, d[i])
    return T @ trans(0, 0, flange)


DH = {
    "planar_2r": lambda q: standard_dh(q, [0, 0], [1.0, 0.8], [0, 0]),
    "puma560": lambda q: standard_dh(
        q,
        [26.45 * 0.0254, 0, 0.15005, 0.4318, 0, 0],  # Robotics Toolbox: 26.45 in
        [0, 0.4318, 0.0203, 0, 0, 0],
        [PI / 2, 0, -PI / 2, PI / 2, -PI / 2, 0],
    ),
    "ur5": lambda q: standard_dh(
        q,
        [0.089159, 0, 0, 0.10915, 0.09465, 0.0823],
        [0, -0.425, -0.39225, 0, 0, 0],
        [PI / 2, 0, 0, PI / 2, -PI / 2, 0],
    ),
    "panda": lambda q: modified_dh(
        q,
        [0, 0, 0, 0.0825, -0.0825, 0, 0.088],
        [0.333, 0, 0.316, 0, 0.384, 0, 0],
        [0, -PI / 2, PI / 2, PI / 2, -PI / 2, PI / 2, PI / 2],
        0.107,
    ),
}

LIMITS = {
    "planar_2r": [(-PI, PI)] * 2,
    "puma560": [  # also the Robotics Toolbox qlim, checked below
        (a * DEG, b * DEG)
        for a, b in [(-160, 160), (-45, 225), (-225, 45), (-110, 170), (-100, 100), (-266, 266)]
    ],
    "ur5": [(-2 * PI, 2 * PI)] * 6,
    "panda": [
        (-2.8973, 2.8973),
        (-1.7628, 1.7628),
        (-2.8973, 2.8973),
        (-3.0718, -0.0698),
        (-2.8973, 2.8973),
        (-0.0175, 3.7525),
        (-2.8973, 2.8973),
    ],
}
VELOCITY = {"ur5": [PI] * 6, "panda": [2.175] * 4 + [2.61] * 3}
ACCELERATION = {"panda": [15, 7.5, 10, 12.5, 15, 20, 20]}


def random_q(robot, n: int, seed: int = 0, margin: float = 0.5) -> np.ndarray:
    """Uniform configurations inside the limits, widened by ``margin`` rad (FK has no limits)."""
    lo, hi = robot.position_limits[:, 0] - margin, robot.position_limits[:, 1] + margin
    return np.random.default_rng(seed).uniform(lo, hi, (n, robot.dof))


@pytest.mark.parametrize("name", sorted(DH))
def test_fk_equals_dh_at_1000_configurations(name: str) -> None:
    robot = registry.get(name)
    qs = random_q(robot, 1000)
    expected = DH[name](qs)
    many = robot.fk_many(qs)
    single = np.array([robot.fk(q) for q in qs])
    worst = np.abs(single - expected).max(axis=(1, 2))
    assert worst.max() <= 1e-9, f"{name}: FK != DH at q={qs[worst.argmax()].tolist()}"
    assert np.abs(many - expected).max() <= 1e-9
    assert np.abs(many - single).max() <= 1e-12


@pytest.mark.parametrize("name", sorted(DH))
def test_joint_zero_and_base_frame(name: str) -> None:
    """Same joint zeros and signs: FK at q = 0 and at +-0.1 rad per joint equals DH."""
    robot = registry.get(name)
    qs = np.vstack([np.zeros(robot.dof), 0.1 * np.eye(robot.dof), -0.1 * np.eye(robot.dof)])
    assert np.abs(robot.fk_many(qs) - DH[name](qs)).max() <= 1e-12


def test_planar_reach_is_the_annulus() -> None:
    robot = registry.get("planar_2r")
    r = np.linalg.norm(robot.fk_many(random_q(robot, 2000, margin=0))[:, :2, 3], axis=1)
    assert r.min() >= 0.2 - 1e-12 and r.max() <= 1.8 + 1e-12
    assert robot.task_space == "position_xy"
    assert np.allclose(robot.fk(np.zeros(2))[:3, 3], [1.8, 0, 0])


@pytest.mark.parametrize("name", sorted(LIMITS))
def test_published_limits(name: str) -> None:
    robot = registry.get(name)
    np.testing.assert_allclose(robot.position_limits, LIMITS[name], rtol=0, atol=1e-12)
    if name in VELOCITY:
        np.testing.assert_allclose(robot.velocity_limits, VELOCITY[name], rtol=0, atol=1e-12)
    if name in ACCELERATION:
        np.testing.assert_allclose(robot.acceleration_limits, ACCELERATION[name], rtol=0, atol=0)
    assert np.all(robot.velocity_limits > 0) and np.all(robot.acceleration_limits > 0)
    assert robot.velocity_limits.shape == robot.acceleration_limits.shape == (robot.dof,)


@pytest.mark.parametrize("name", sorted(DH))
def test_every_limit_has_a_stated_source(name: str) -> None:
    robot = registry.get(name)
    for kind in ("position", "velocity", "acceleration"):
        assert len(robot.sources.get(kind, "")) > 10, f"{name}: no source for {kind} limits"
    desc = registry.DESCRIPTIONS[name]
    text = resources.files("robots").joinpath("urdf", desc.urdf).read_text()
    assert re.search(r"Limits?:|[Vv]elocity", text), "the URDF states where its limits come from"
    assert "<mesh" not in text and "<visual" not in text


@pytest.mark.parametrize("name", sorted(DH))
def test_home_is_inside_limits_and_away_from_singularities(name: str) -> None:
    robot = registry.get(name)
    lo, hi = robot.position_limits.T
    assert np.all(robot.home >= lo) and np.all(robot.home <= hi)
    assert robot.singular_values(robot.home)[-1] > 0.1
    assert robot.manipulability(robot.home) > 1e-3


def test_registry_names_and_unknown_robot() -> None:
    from core.errors import UnknownRobot

    assert registry.names() == ["panda", "planar_2r", "puma560", "ur5"]
    with pytest.raises(UnknownRobot) as err:
        registry.get("kuka")
    assert err.value.extra["available"] == registry.names()
    assert registry.get("ur5") is registry.get("ur5")
    assert registry.resolve("ur5") is registry.get("ur5")


def test_puma560_equals_the_cited_robotics_toolbox_model() -> None:
    """The URDF cites Corke's Robotics Toolbox: its Puma560 (base 26.45 in = 0.67183 m) gives the same
    tool pose, and the same position limits, at 200 configurations."""
    rtb = pytest.importorskip("roboticstoolbox")
    reference = rtb.models.DH.Puma560()
    robot = registry.get("puma560")
    qs = random_q(robot, 200, seed=3)
    expected = np.array([reference.fkine(q).A for q in qs])
    assert np.abs(robot.fk_many(qs) - expected).max() <= 1e-12
    np.testing.assert_allclose(robot.position_limits, reference.qlim.T, rtol=0, atol=1e-6)
