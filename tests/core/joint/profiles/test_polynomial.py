"""Cubic and quintic profiles: the notes' matrices, end conditions in physical units, time scaling,
exact peaks (closed forms rest to rest, root search otherwise), batched durations, sampling."""

from __future__ import annotations

import numpy as np
import pytest

from core.joint.durations import (
    CUBIC_PEAK_ACCELERATION,
    CUBIC_PEAK_VELOCITY,
    QUINTIC_PEAK_ACCELERATION,
    QUINTIC_PEAK_VELOCITY,
)
from core.joint.peaks import abs_peak_on_unit, polyder
from core.joint.profiles.linear import LinearProfile
from core.joint.profiles.polynomial import CUBIC_MATRIX, QUINTIC_MATRIX, PolynomialProfile
from core.joint.profiles.trapezoidal import TrapezoidalProfile

RNG_SEED = 20240402


def random_case(rng: np.random.Generator) -> dict:
    dof = int(rng.integers(1, 8))
    return {
        "dof": dof,
        "T": float(rng.uniform(0.05, 20.0)),
        "q0": rng.uniform(-3, 3, dof),
        "q1": rng.uniform(-3, 3, dof),
        "v0": rng.uniform(-2, 2, dof),
        "v1": rng.uniform(-2, 2, dof),
        "a0": rng.uniform(-5, 5, dof),
        "a1": rng.uniform(-5, 5, dof),
    }


def near_ends(T: float) -> np.ndarray:
    """Times next to 0 and T, so the polynomial itself is checked, not the pinned end values."""
    return np.array([np.nextafter(0.0, 1.0), np.nextafter(T, 0.0)])


def test_notes_inverse_matrix_of_the_cubic() -> None:
    # Course notes eq. (2): the inverse printed in the notes.
    printed = np.array([[2, 1, -2, 1], [-3, -2, 3, -1], [0, 1, 0, 0], [1, 0, 0, 0]], dtype=float)
    assert np.allclose(np.linalg.inv(CUBIC_MATRIX), printed, atol=1e-14)
    assert abs(np.linalg.det(QUINTIC_MATRIX)) > 0.5


@pytest.mark.parametrize("kind", ["cubic", "quintic"])
def test_end_conditions_in_physical_units(kind: str) -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(200):
        c = random_case(rng)
        a0, a1 = (c["a0"], c["a1"]) if kind == "quintic" else (None, None)
        prof = PolynomialProfile(c["q0"], c["q1"], c["T"], c["v0"], c["v1"], a0, a1)
        for t in (near_ends(c["T"]), np.array([0.0, c["T"]])):
            q, v, a = prof(t, 0), prof(t, 1), prof(t, 2)
            np.testing.assert_allclose(q, [c["q0"], c["q1"]], rtol=0, atol=1e-9)
            np.testing.assert_allclose(v, [c["v0"], c["v1"]], rtol=0, atol=1e-9)
            if kind == "quintic":
                np.testing.assert_allclose(a, [c["a0"], c["a1"]], rtol=0, atol=1e-9)


@pytest.mark.parametrize("kind", ["linear", "trapezoidal"])
def test_end_conditions_rest_to_rest(kind: str) -> None:
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(200):
        c = random_case(rng)
        if kind == "linear":
            prof = LinearProfile(c["q0"], c["q1"], c["T"])
        else:
            prof = TrapezoidalProfile(c["q0"], c["q1"], c["T"], rng.uniform(1, 50, c["dof"]))
        ends = np.array([0.0, c["T"]])
        np.testing.assert_allclose(prof(ends, 0), [c["q0"], c["q1"]], rtol=0, atol=1e-9)
        np.testing.assert_array_equal(prof(ends, 1), np.zeros((2, c["dof"])))
        np.testing.assert_allclose(prof(near_ends(c["T"]), 0), [c["q0"], c["q1"]], atol=1e-9)


@pytest.mark.parametrize("kind", ["cubic", "quintic", "trapezoidal"])
def test_derivatives_match_finite_differences(kind: str) -> None:
    """Time scaling done right: velocity and acceleration are the time derivatives in [s]."""
    rng = np.random.default_rng(RNG_SEED + 2)
    for _ in range(30):
        c = random_case(rng)
        if kind == "trapezoidal":
            prof = TrapezoidalProfile(c["q0"], c["q1"], c["T"], np.full(c["dof"], np.inf))
        else:
            quintic = kind == "quintic"
            a0, a1 = (c["a0"], c["a1"]) if quintic else (None, None)
            prof = PolynomialProfile(c["q0"], c["q1"], c["T"], c["v0"], c["v1"], a0, a1)
        t = np.linspace(0.05, 0.95, 37) * c["T"]
        h = 1e-5 * c["T"]
        for order in (1, 2):
            fd = (prof(t + h, order - 1) - prof(t - h, order - 1)) / (2 * h)
            scale = 1.0 + np.abs(prof(t, order)).max()
            kink = kind == "trapezoidal" and order == 2  # acceleration steps at phase switches
            if not kink:
                np.testing.assert_allclose(prof(t, order), fd, rtol=0, atol=1e-5 * scale)


def test_rest_to_rest_peaks_match_the_closed_forms() -> None:
    rng = np.random.default_rng(RNG_SEED + 3)
    q0, q1, T = rng.uniform(-2, 2, 5), rng.uniform(-2, 2, 5), 1.7
    zero = np.zeros(5)
    dq = np.abs(q1 - q0)
    for prof, kv, ka in (
        (PolynomialProfile(q0, q1, T, zero, zero), CUBIC_PEAK_VELOCITY, CUBIC_PEAK_ACCELERATION),
        (
            PolynomialProfile(q0, q1, T, zero, zero, zero, zero),
            QUINTIC_PEAK_VELOCITY,
            QUINTIC_PEAK_ACCELERATION,
        ),
    ):
        vel, acc, _ = prof.peaks()
        np.testing.assert_allclose(vel, kv * dq / T, rtol=1e-12)
        np.testing.assert_allclose(acc, ka * dq / T**2, rtol=1e-12)
        dense = np.linspace(0, T, 200_001)
        np.testing.assert_allclose(np.abs(prof(dense, 1)).max(axis=0), vel, rtol=1e-9)
        # The closed forms (REST_PEAKS) equal the general root search on the derivatives.
        for k, got in enumerate(prof.peaks(), start=1):
            found = abs_peak_on_unit(polyder(prof.coeffs, k)) / T**k
            np.testing.assert_allclose(got, found, rtol=1e-12)
    assert QUINTIC_PEAK_VELOCITY == 1.875 and round(QUINTIC_PEAK_ACCELERATION, 4) == 5.7735


def test_exact_peaks_bound_dense_sampling_from_above() -> None:
    rng = np.random.default_rng(RNG_SEED + 4)
    for _ in range(100):
        c = random_case(rng)
        prof = PolynomialProfile(c["q0"], c["q1"], c["T"], c["v0"], c["v1"], c["a0"], c["a1"])
        vel, acc, _ = prof.peaks()
        t = np.linspace(0, c["T"], 20_001)
        dense_v, dense_a = np.abs(prof(t, 1)).max(axis=0), np.abs(prof(t, 2)).max(axis=0)
        assert np.all(dense_v <= vel * (1 + 1e-12) + 1e-12)
        assert np.all(dense_a <= acc * (1 + 1e-12) + 1e-12)
        np.testing.assert_allclose(dense_v, vel, rtol=1e-6)
        np.testing.assert_allclose(dense_a, acc, rtol=1e-6)


def test_batched_durations_equal_one_at_a_time() -> None:
    rng = np.random.default_rng(RNG_SEED + 5)
    c = random_case(rng)
    durations = np.geomspace(0.1, 10, 7)
    args = (c["q0"], c["q1"])
    bcs = (c["v0"], c["v1"], c["a0"], c["a1"])
    vel, acc, _ = PolynomialProfile(*args, durations[:, None], *bcs).peaks()
    for i, T in enumerate(durations):
        v1, a1, _ = PolynomialProfile(*args, T, *bcs).peaks()
        np.testing.assert_allclose(vel[i], v1, rtol=1e-12)
        np.testing.assert_allclose(acc[i], a1, rtol=1e-12)


def test_sample_equals_three_calls() -> None:
    """``sample`` (powers of s shared by the three orders) equals ``profile(t, order)``; the ends
    are the boundary conditions exactly."""
    rng = np.random.default_rng(RNG_SEED + 40)
    q0, q1, v0, v1, a0, a1 = rng.normal(size=(6, 4))
    t = np.concatenate([[0.0, 2.5], rng.uniform(0.0, 2.5, 300)])
    for profile in (
        PolynomialProfile(q0, q1, 2.5, v0, v1, a0, a1),
        PolynomialProfile(q0, q1, 2.5, v0, v1),
        LinearProfile(q0, q1, 2.5),
    ):
        for order, got in enumerate(profile.sample(t)):
            np.testing.assert_allclose(got, profile(t, order), rtol=0, atol=1e-12)
        q = profile.sample(t)[0]
        np.testing.assert_array_equal(q[0], q0)
        np.testing.assert_array_equal(q[1], q1)
