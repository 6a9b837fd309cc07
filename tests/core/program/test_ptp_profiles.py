"""PTP joint profiles in programs: unblended PTPs between stops follow their profile, rest to rest.

References: Ruckig called directly (jerk_limited durations), the closed forms of the quintic
(peak speed 15/8 d/T, peak acceleration 10/sqrt(3) d/T^2) and of the synchronized trapezoid, finite
differences of densely returned samples.
"""

from __future__ import annotations

import numpy as np
import pytest
import ruckig

from core.errors import InputError
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from robots import registry

PANDA = registry.get("panda")
UR5 = registry.get("ur5")
Q0 = PANDA.home
Q1 = Q0 + np.array([0.6, -0.3, 0.4, 0.5, -0.7, 0.3, 0.9])
Q2 = Q0 + np.array([-0.2, 0.2, -0.5, 0.3, 0.4, -0.2, -0.6])


def _ptp(goal: np.ndarray, **kw) -> Segment:
    return Segment("ptp", goal_positions=goal, **kw)


def _window(result, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    seg = result.segments[i]
    tr = result.trajectory
    sel = (tr.times >= seg.start_time - 1e-12) & (tr.times <= seg.end_time + 1e-12)
    return tr.times[sel], tr.positions[sel], tr.velocities[sel], tr.accelerations[sel]


def test_jerk_limited_ptp_is_ruckigs_time_optimal_profile_within_the_panda_limits():
    scale = 0.5
    task = ProgramTask(
        PANDA,
        Q0,
        (_ptp(Q1, profile="jerk_limited", velocity_scale=scale), _ptp(Q2)),
        sample_period=5e-4,
    )
    result = plan_program(task)
    inp = ruckig.InputParameter(7)
    inp.current_position, inp.target_position = Q0, Q1
    inp.max_velocity = PANDA.velocity_limits * scale
    inp.max_acceleration = PANDA.acceleration_limits
    inp.max_jerk = PANDA.jerk_limits
    ref = ruckig.Trajectory(7)
    ruckig.Ruckig(7).calculate(inp, ref)
    seg = result.segments[0]
    assert seg.diagnostics["timing"] == "jerk_limited"
    assert result.segments[1].diagnostics["timing"] == "time_optimal"
    assert seg.start_time == 0.0
    assert seg.end_time == pytest.approx(ref.duration, rel=1e-12)
    t, q, qd, qdd = _window(result, 0)
    assert np.abs(q[0] - Q0).max() < 1e-12 and np.abs(q[-1] - Q1).max() < 1e-12
    assert np.abs(qd[[0, -1]]).max() < 1e-12 and np.abs(qdd[[0, -1]]).max() < 1e-12
    # Ruckig's own samples agree with ours.
    k = len(t) // 3
    pos, vel, acc = ref.at_time(t[k])
    assert np.abs(q[k] - pos).max() < 1e-9
    assert np.abs(qd[k] - vel).max() < 1e-9
    assert np.abs(qdd[k] - acc).max() < 1e-9
    # Within the scaled velocity limit, the acceleration limit and the jerk limit (finite
    # differences of the accelerations: constant-jerk phases make them exact up to rounding).
    assert np.all(np.abs(qd) <= PANDA.velocity_limits * scale * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= PANDA.acceleration_limits * (1 + 1e-9))
    jerk = np.diff(qdd, axis=0) / np.diff(t)[:, None]
    assert np.all(np.abs(jerk) <= PANDA.jerk_limits * (1 + 1e-6))
    assert np.abs(jerk).max() > 0.5 * PANDA.jerk_limits.min()  # the limit is used, not avoided
    # The exact peak jerk of the program covers the profile's.
    assert np.all(result.trajectory.peak_jerk >= np.abs(jerk).max(axis=0) * (1 - 1e-6))


def test_quintic_ptp_meets_its_closed_form():
    task = ProgramTask(
        PANDA, Q0, (_ptp(Q1, profile="quintic", acceleration_scale=0.3),), sample_period=1e-3
    )
    result = plan_program(task)
    d = np.abs(Q1 - Q0)
    v, a = PANDA.velocity_limits, PANDA.acceleration_limits * 0.3
    T = np.max(np.maximum(15 * d / (8 * v), np.sqrt(10 * d / (np.sqrt(3) * a))))
    assert result.trajectory.duration == pytest.approx(T, rel=1e-9)
    t, q, qd, _ = _window(result, 0)
    u = t / T
    s = u**3 * (10 - 15 * u + 6 * u**2)
    assert np.abs(q - (Q0 + s[:, None] * (Q1 - Q0))).max() < 1e-9
    assert np.abs(qd).max(axis=0) == pytest.approx(15 / 8 * d / T, rel=1e-3)


def test_trapezoidal_ptp_is_the_synchronized_trapezoid():
    result = plan_program(ProgramTask(PANDA, Q0, (_ptp(Q1, profile="trapezoidal"),)))
    d = np.abs(Q1 - Q0)
    v, a = PANDA.velocity_limits, PANDA.acceleration_limits
    each = np.where(d > v * v / a, d / v + v / a, 2 * np.sqrt(d / a))
    assert result.trajectory.duration == pytest.approx(each.max(), rel=1e-9)
    _, _, qd, qdd = _window(result, 0)
    assert np.all(np.abs(qd) <= v * (1 + 1e-9)) and np.all(np.abs(qdd) <= a * (1 + 1e-9))


def test_jerk_limited_without_jerk_limits_is_validation_at_the_profile():
    q1 = UR5.home + 0.2
    with pytest.raises(InputError) as e:
        plan_program(ProgramTask(UR5, UR5.home, (_ptp(q1), _ptp(UR5.home, profile="jerk_limited"))))
    assert e.value.field == ("segments", 1, "profile")


def test_a_profile_inside_a_blend_is_ignored_with_a_warning():
    lin_goal = PANDA.fk(Q1)
    lin_goal[:3, 3] += [0.0, 0.0, -0.1]
    plain = (_ptp(Q1, blend_radius=0.02), Segment("lin", goal_pose=lin_goal))
    asked = (_ptp(Q1, blend_radius=0.02, profile="jerk_limited"), plain[1])
    a = plan_program(ProgramTask(PANDA, Q0, plain))
    b = plan_program(ProgramTask(PANDA, Q0, asked))
    assert np.array_equal(a.trajectory.positions, b.trajectory.positions)
    assert any("profile 'jerk_limited' ignored" in w for w in b.warnings)
    assert not any("ignored" in w for w in a.warnings)
