"""The scalar and LAPACK pieces of a tick against numpy/scipy references: the pose error against
``so3.log`` and scipy's rotation vector, the singular values and thin SVD against
``np.linalg.svd``, the Cholesky feed-forward ratio against the SVD form."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from core.cartesian.rate.control import nominal_timing
from core.cartesian.rate.qp import RateLimits, rate_bounds
from core.cartesian.rate.setpoint import LineSetpoint, PathSetpoint
from core.cartesian.rate.steps import (
    clear_ticks,
    feedforward_ratio,
    pose_error,
    singular_values,
    smallest_singular_value,
    svd,
)
from core.cartesian.validate import validated_line
from core.geometry import so3
from tests.core.cartesian.rate.scenarios import SCENARIOS


@pytest.mark.parametrize("scale", [1e-5, 0.01, 0.5, 1.5, 3.0])
def test_pose_error_is_so3_log_of_the_orientation_error(scale):
    rng = np.random.default_rng(int(scale * 1e5))
    for _ in range(50):
        R = Rotation.random(random_state=rng).as_matrix()
        R_d = Rotation.from_rotvec(rng.normal(size=3) * scale).as_matrix() @ R
        M = R_d @ R.T
        p, p_d = rng.normal(size=3), rng.normal(size=3)
        e = np.array(pose_error(p.tolist(), p_d.tolist(), M.tolist()))
        assert np.array_equal(e[:3], p_d - p)
        # The same formula as so3.log, in scalar Python arithmetic instead of numpy's kernels:
        # equal to the last bit or two (BLAS/SIMD rounding differs between machines: 1 ulp here).
        np.testing.assert_allclose(e[3:], so3.log(M), rtol=0, atol=1e-15)
        assert np.allclose(e[3:], Rotation.from_matrix(M).as_rotvec(), atol=1e-12)
    assert pose_error([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], None) == [-1.0, -2.0, -3.0, 0, 0, 0]


def test_svd_pieces_match_numpy():
    rng = np.random.default_rng(4)
    for shape in [(6, 6), (6, 7), (2, 2), (6, 3)]:
        J = rng.normal(size=shape)
        U, S, Vt = svd(J)
        U0, S0, Vt0 = np.linalg.svd(J, full_matrices=False)
        assert np.array_equal(S, S0)  # the same LAPACK routine: the same values
        assert np.allclose((U * S) @ Vt, J, rtol=0, atol=1e-13)
        assert np.allclose(np.abs(U), np.abs(U0), atol=1e-12)
        assert np.allclose(np.abs(Vt), np.abs(Vt0), atol=1e-12)
        assert np.allclose(singular_values(J), S0, rtol=0, atol=1e-14)


@pytest.mark.parametrize("lam", [0.0, 3e-3, 0.04])
def test_feedforward_ratio_equals_the_svd_form(lam):
    rng = np.random.default_rng(int(lam * 1e4))
    vmax = rng.uniform(1.0, 3.0, 7)
    for _ in range(50):
        J, twist = rng.normal(size=(6, 7)), rng.normal(size=6)
        U, S, Vt = np.linalg.svd(J, full_matrices=False)
        qd = Vt.T @ (S / (S * S + lam * lam) * (U.T @ twist))
        exact = np.max(np.abs(qd) / vmax)
        shift = lam * lam * np.eye(6) if lam else None
        ratio = feedforward_ratio(J, J @ J.T, shift, twist, vmax)
        assert ratio == pytest.approx(exact, rel=1e-11)
    zero = np.zeros((6, 7))
    assert feedforward_ratio(zero, zero @ zero.T, None, np.ones(6), vmax) == np.inf  # singular


def test_smallest_singular_value_by_the_gram_matrix():
    """Within 1e-13 relative of numpy's SVD where the Gram route applies, and gesdd's value
    exactly below the threshold (near a singularity, where the Gram route has no digit left)."""
    rng = np.random.default_rng(8)
    for shape in [(6, 7), (6, 6), (2, 2), (2, 7), (1, 3)]:
        for _ in range(50):
            J = rng.normal(size=shape) * rng.uniform(0.1, 2.0)
            exact = np.linalg.svd(J, compute_uv=False)[-1]
            got = smallest_singular_value(J, J @ J.T, 0.1)
            if exact >= 0.11:
                assert got == pytest.approx(exact, rel=1e-13), (shape, J.tolist())
            elif exact < 0.09:
                assert got == singular_values(J)[-1]
    U, _, Vt = np.linalg.svd(rng.normal(size=(6, 7)), full_matrices=False)
    for tiny in (1e-3, 1e-9, 0.0):
        J = (U * [2.0, 1.5, 1.0, 0.8, 0.5, tiny]) @ Vt
        assert smallest_singular_value(J, J @ J.T, 0.1) == singular_values(J)[-1]
        assert singular_values(J)[-1] == pytest.approx(tiny, abs=1e-15)


@pytest.mark.parametrize("seed", range(4))
def test_clear_ticks_keep_the_bounds_at_the_velocity_limits(seed):
    """For every tick ``clear_ticks`` promises, whatever rates within the bounds the joints take
    (random, or full speed towards the nearer limit), ``rate_bounds`` is exactly the velocity
    limits and ``q + qd dt`` stays inside the position limits; and the count is within two ticks
    of where full speed makes a bound tighter."""
    rng = np.random.default_rng(seed)
    dof, most = 7, 10**6
    for case in range(200):
        lo = rng.uniform(-3.0, -0.5, dof)
        limits = RateLimits(
            np.stack([lo, lo + rng.uniform(0.5, 6.0, dof)], axis=1), rng.uniform(0.5, 3.0, dof)
        )
        vmax, dt = limits.velocity, float(rng.choice([1e-3, 4e-3, 0.05]))
        span = limits.position[:, 1] - lo
        gaps = np.minimum(rng.uniform(0.0, 40.0, dof) * vmax * dt, span / 3)  # to the nearer limit
        side = rng.integers(0, 2, dof)
        q = np.where(side == 0, lo + gaps, limits.position[:, 1] - gaps)
        raw = (limits.position.T - q) / dt
        count = clear_ticks(raw, vmax, most)
        toward = np.where(side == 0, -vmax, vmax)
        for worst in (True, False):
            x = q.copy()
            for i in range(1, count + 1):
                x += (toward if worst else rng.uniform(-vmax, vmax)) * dt
                lower, upper = rate_bounds(x, limits, dt)
                assert np.array_equal(lower, -vmax) and np.array_equal(upper, vmax), (case, i)
                assert np.all(x + toward * dt > lo) and np.all(
                    x + toward * dt < limits.position[:, 1]
                )
        x = q + (count + 2) * toward * dt  # full speed: a bound is tighter within two more ticks
        lower, upper = rate_bounds(x, limits, dt)
        assert np.any(lower > -vmax) or np.any(upper < vmax), (case, count)
    raw = np.array([[-np.inf, -5.0], [np.inf, 5.0]])
    assert clear_ticks(raw, np.ones(2), most) == 3
    assert clear_ticks(np.array([[-np.inf], [np.inf]]), np.ones(1), most) == most
    assert clear_ticks(np.array([[np.nan], [1e9]]), np.ones(1), most) == 0
    assert clear_ticks(np.array([[-2.5], [1e9]]), np.ones(1), most) == 0  # within 3 ticks


def test_tabulated_setpoints_equal_the_per_tick_ones():
    pytest.importorskip("robots.registry")
    task = SCENARIOS["puma_wrist_dls"][0]()
    line = validated_line(task)
    timing = nominal_timing(task, line)
    dt = timing.duration / 200
    setpoint = LineSetpoint(line, timing, dt, 200)
    generic = PathSetpoint(line, timing, dt, 200)  # the arc's code path, on the same line
    for tau0 in (0.0, 0.37 * dt, 150.5 * dt):  # the last block runs past the end (held there)
        s, sd, p_d, R_d, u = setpoint.block(tau0, 80)
        g_s, g_sd, g_p, g_R, g_u = generic.block(tau0, 80)
        tau = tau0
        for k in range(80):
            s_k, sd_k, p_k, R_k, u_k = setpoint(tau)
            assert (s[k], sd[k], p_d[k]) == (s_k, sd_k, p_k)
            assert np.array_equal(R_d[k], np.reshape(R_k, (3, 3)))
            assert u[k] is u_k is setpoint.unit
            # the generic (arc) setpoint: the same poses and unit twists to rounding
            gs_k, gsd_k, gp_k, gR_k, gu_k = generic(tau)
            assert (g_s[k], g_sd[k]) == (gs_k, gsd_k) == (s_k, sd_k)
            np.testing.assert_allclose(g_p[k], p_k, atol=1e-12)
            np.testing.assert_allclose(gp_k, p_k, atol=1e-12)
            np.testing.assert_allclose(g_R[k], np.reshape(R_k, (3, 3)), atol=1e-12)
            np.testing.assert_allclose(np.reshape(gR_k, (3, 3)), g_R[k], atol=1e-12)
            np.testing.assert_allclose(g_u[k], u_k, atol=1e-12)
            np.testing.assert_allclose(gu_k, u_k, atol=1e-12)
            tau = tau + 1.0 * dt
