"""The one SO(3) module against scipy's Rotation: log (batched and one matrix, half turns and tiny
angles included), exp, slerp, skew."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from core.geometry import so3


def _cases() -> list[Rotation]:
    rng = np.random.default_rng(5)
    axes = Rotation.random(500, random_state=6).as_rotvec()
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return [
        Rotation.random(3000, random_state=7),
        Rotation.from_rotvec(rng.normal(size=(500, 3)) * 1e-9),
        Rotation.from_rotvec(rng.normal(size=(500, 3)) * 1e-3),
        Rotation.from_rotvec(axes * (np.pi - rng.uniform(0.0, 1e-6, (500, 1)))),
        Rotation.from_rotvec(axes * (np.pi - rng.uniform(0.0, 2e-4, (500, 1)))),
        Rotation.from_rotvec(np.pi * np.eye(3)),
        Rotation.identity(2),
    ]


def test_log_equals_scipy_everywhere_half_turns_included() -> None:
    for rotations in _cases():
        matrices = rotations.as_matrix()
        expected = Rotation.from_matrix(matrices).as_rotvec()
        np.testing.assert_allclose(so3.log(matrices), expected, rtol=0, atol=1e-12)
        # One matrix at a time takes the scalar route (and the batched one near a half turn).
        one = np.array([so3.log(R) for R in matrices[:200]])
        np.testing.assert_allclose(one, expected[:200], rtol=0, atol=1e-12)


def test_log_keeps_leading_axes() -> None:
    R = Rotation.random(12, random_state=1).as_matrix().reshape(3, 4, 3, 3)
    assert so3.log(R).shape == (3, 4, 3)


def test_exp_equals_scipy_and_inverts_log() -> None:
    rng = np.random.default_rng(2)
    v = np.concatenate(
        [rng.normal(size=(500, 3)), rng.normal(size=(50, 3)) * 1e-5, np.zeros((1, 3))]
    )
    np.testing.assert_allclose(so3.exp(v), Rotation.from_rotvec(v).as_matrix(), rtol=0, atol=1e-14)
    inside = v[np.linalg.norm(v, axis=1) < np.pi - 1e-3]
    np.testing.assert_allclose(so3.log(so3.exp(inside)), inside, rtol=0, atol=1e-12)


def test_slerp_equals_scipy_slerp() -> None:
    s = np.linspace(0.0, 1.0, 33)
    for seed in range(20):
        R0 = Rotation.random(random_state=seed).as_matrix()
        R1 = Rotation.random(random_state=100 + seed).as_matrix() if seed % 4 else R0
        expected = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([R0, R1])))(s).as_matrix()
        got = so3.slerp(R0, so3.log(R0.T @ R1), s)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_skew_is_the_cross_product() -> None:
    rng = np.random.default_rng(3)
    u, v = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    np.testing.assert_allclose(
        (so3.skew(u) @ v[:, :, None])[:, :, 0], np.cross(u, v), rtol=0, atol=1e-15
    )
