"""PTP joint profiles in programs: unblended PTPs between stops follow their profile, rest to rest,
synchronously: every returned point of the PTP on the straight joint segment.

References: Ruckig called directly with phase synchronization (jerk_limited durations and samples),
the closed forms of the quintic (peak speed 15/8 d/T, peak acceleration 10/sqrt(3) d/T^2) and of
the trapezoid of the common s (limits per unit s: the smallest v_j / |dq_j| and a_j / |dq_j|),
finite differences of densely returned samples.
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
Q3 = Q0 + np.array([0.3, -0.8, 0.4, 0.5, -0.5, 0.3, 0.6])


def _ptp(goal: np.ndarray, **kw) -> Segment:
    return Segment("ptp", goal_positions=goal, **kw)


def _window(result, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    seg = result.segments[i]
    tr = result.trajectory
    sel = (tr.times >= seg.start_time - 1e-12) & (tr.times <= seg.end_time + 1e-12)
    return tr.times[sel], tr.positions[sel], tr.velocities[sel], tr.accelerations[sel]


def off_segment(q: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> tuple[float, np.ndarray]:
    """Largest distance [rad] of the rows of ``q`` from the line through q0 and q1, and their
    parameters u along it (the projection: 0 at q0, 1 at q1)."""
    d = q1 - q0
    u = (q - q0) @ d / (d @ d)
    return float(np.abs(q - q0 - u[:, None] * d).max()), u


def ruckig_reference(goal: np.ndarray, scale: float, sync) -> ruckig.Trajectory:
    inp = ruckig.InputParameter(7)
    inp.current_position, inp.target_position = Q0, goal
    inp.max_velocity = PANDA.velocity_limits * scale
    inp.max_acceleration = PANDA.acceleration_limits
    inp.max_jerk = PANDA.jerk_limits
    inp.synchronization = sync
    ref = ruckig.Trajectory(7)
    ruckig.Ruckig(7).calculate(inp, ref)
    return ref


def test_jerk_limited_ptp_is_ruckigs_phase_synchronized_profile_within_the_panda_limits():
    """Joint 1 moves farthest and has the Panda's lowest limits: Ruckig can phase-synchronize
    (``Synchronization.Phase``, a straight line) and is then time-optimal among straight motions:
    our law of the common s is that profile."""
    scale = 0.5
    task = ProgramTask(
        PANDA,
        Q0,
        (_ptp(Q3, profile="jerk_limited", velocity_scale=scale), _ptp(Q2)),
        sample_period=5e-4,
    )
    result = plan_program(task)
    ref = ruckig_reference(Q3, scale, ruckig.Synchronization.Phase)
    # Ruckig phase-synchronized this move (no fallback to time synchronization): a straight line.
    probe = np.array([ref.at_time(x)[0] for x in np.linspace(0.0, ref.duration, 50)])
    assert off_segment(probe, Q0, Q3)[0] < 1e-9
    seg = result.segments[0]
    assert seg.diagnostics["timing"] == "jerk_limited"
    assert (
        result.segments[1].diagnostics["timing"] == "time_optimal"
    )  # the program default (was trapezoidal before round 3)
    assert seg.start_time == 0.0
    assert seg.end_time == pytest.approx(ref.duration, rel=1e-9)
    t, q, qd, qdd = _window(result, 0)
    assert np.abs(q[0] - Q0).max() < 1e-12 and np.abs(q[-1] - Q3).max() < 1e-12
    assert np.abs(qd[[0, -1]]).max() < 1e-12 and np.abs(qdd[[0, -1]]).max() < 1e-12
    off, u = off_segment(q, Q0, Q3)
    assert off < 1e-9 and u.min() >= -1e-12 and u.max() <= 1 + 1e-12
    # Ruckig's own samples agree with ours.
    for k in (len(t) // 5, len(t) // 3, len(t) // 2):
        pos, vel, acc = ref.at_time(t[k])
        assert np.abs(q[k] - pos).max() < 1e-8
        assert np.abs(qd[k] - vel).max() < 1e-8
        assert np.abs(qdd[k] - acc).max() < 1e-7
    # Within the scaled velocity limit, the acceleration limit and the jerk limit (finite
    # differences of the accelerations: constant-jerk phases make them exact up to rounding).
    assert np.all(np.abs(qd) <= PANDA.velocity_limits * scale * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= PANDA.acceleration_limits * (1 + 1e-9))
    jerk = np.diff(qdd, axis=0) / np.diff(t)[:, None]
    assert np.all(np.abs(jerk) <= PANDA.jerk_limits * (1 + 1e-6))
    assert np.abs(jerk).max() > 0.5 * PANDA.jerk_limits.min()  # the limit is used, not avoided
    # The exact peak jerk of the program covers the profile's.
    assert np.all(result.trajectory.peak_jerk >= np.abs(jerk).max(axis=0) * (1 - 1e-6))


def test_jerk_limited_ptp_where_ruckig_cannot_phase_synchronize_stays_straight():
    """Q0 -> Q1: the joints limiting velocity, acceleration and jerk per unit s differ, so Ruckig's
    phase synchronization falls back to time synchronization (off the segment by 7e-3 rad; the
    program's PTP was that, 0.021 rad off at full scale). Ours stays on the segment, no faster
    than Ruckig's unconstrained time-optimal move, within the limits."""
    scale = 0.5
    task = ProgramTask(
        PANDA, Q0, (_ptp(Q1, profile="jerk_limited", velocity_scale=scale),), sample_period=5e-4
    )
    result = plan_program(task)
    fallback = ruckig_reference(Q1, scale, ruckig.Synchronization.Phase)
    probe = np.array([fallback.at_time(x)[0] for x in np.linspace(0.0, fallback.duration, 50)])
    assert off_segment(probe, Q0, Q1)[0] > 1e-3
    timed = ruckig_reference(Q1, scale, ruckig.Synchronization.Time)
    assert result.trajectory.duration >= timed.duration * (1 - 1e-12)
    tr = result.trajectory
    off, u = off_segment(tr.positions, Q0, Q1)
    assert off < 1e-9 and u.min() >= -1e-12 and u.max() <= 1 + 1e-12
    assert np.all(tr.peak_velocity <= PANDA.velocity_limits * scale * (1 + 1e-9))
    assert np.all(tr.peak_acceleration <= PANDA.acceleration_limits * (1 + 1e-9))
    assert np.all(tr.peak_jerk <= PANDA.jerk_limits * (1 + 1e-9))
    # time-optimal for s: some joint reaches each of its acceleration and jerk limits
    assert np.max(tr.peak_acceleration / PANDA.acceleration_limits) == pytest.approx(1.0, rel=1e-6)
    assert np.max(tr.peak_jerk / PANDA.jerk_limits) == pytest.approx(1.0, rel=1e-6)


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


def synchronized_trapezoid(d: np.ndarray, v: np.ndarray, a: np.ndarray) -> float:
    """Closed form: the time-optimal trapezoid (or triangle) of s from 0 to 1 under the limits per
    unit s, v_s = min v_j / d_j and a_s = min a_j / d_j."""
    vs, acc = np.min(v / d), np.min(a / d)
    return float(1 / vs + vs / acc if vs * vs / acc <= 1.0 else 2.0 / np.sqrt(acc))


@pytest.mark.parametrize(
    ("goal", "vscale", "ascale"),
    [(Q1, 1.0, 1.0), (Q2, 0.3, 1.0), (Q1, 1.0, 0.05), (Q0 + 0.02, 1.0, 1.0)],
)
def test_trapezoidal_ptp_is_the_trapezoid_of_the_common_s(goal, vscale, ascale):
    """Was: each joint its own trapezoid in the slowest joint's time, up to 0.023 rad off the joint
    segment. Now on the segment to 1e-9, in the closed-form time of the common s, within the
    scaled limits, one joint at its acceleration limit and (when s cruises) one at its velocity
    limit."""
    seg = _ptp(goal, profile="trapezoidal", velocity_scale=vscale, acceleration_scale=ascale)
    result = plan_program(ProgramTask(PANDA, Q0, (seg,), sample_period=1e-3))
    d = np.abs(goal - Q0)
    v, a = PANDA.velocity_limits * vscale, PANDA.acceleration_limits * ascale
    T = synchronized_trapezoid(d, v, a)
    assert result.trajectory.duration == pytest.approx(T, rel=1e-12)
    _, q, qd, qdd = _window(result, 0)
    off, u = off_segment(q, Q0, goal)
    assert off < 1e-9 and u.min() >= -1e-12 and u.max() <= 1 + 1e-12
    assert np.all(np.diff(u) >= -1e-12)  # forward only
    assert np.all(np.abs(qd) <= v * (1 + 1e-9)) and np.all(np.abs(qdd) <= a * (1 + 1e-9))
    assert np.max(np.abs(qdd) / a) == pytest.approx(1.0, rel=1e-9)
    peaks = result.trajectory.peaks
    assert np.all(peaks.velocity <= v * (1 + 1e-12))
    assert np.all(peaks.acceleration <= a * (1 + 1e-12))
    if np.min(v / d) ** 2 / np.min(a / d) < 1.0:  # s cruises: at the velocity limit
        assert np.max(peaks.velocity / v) == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("profile", ["trapezoidal", "quintic", "jerk_limited"])
def test_every_ptp_profile_stays_on_the_joint_segment_between_other_moves(profile):
    """After a time-optimal PTP and before a LIN: the profiled PTP's returned points (its window's
    ends included) lie on its joint segment, its velocity along it."""
    lin_goal = PANDA.fk(Q2)
    lin_goal[:3, 3] += [0.0, 0.05, -0.05]
    segs = (
        _ptp(Q1),
        _ptp(Q2, profile=profile, velocity_scale=0.7),
        Segment("lin", goal_pose=lin_goal),
    )
    result = plan_program(ProgramTask(PANDA, Q0, segs, sample_period=2e-3))
    assert result.segments[1].diagnostics["timing"] == profile
    _, q, qd, _ = _window(result, 1)
    off, u = off_segment(q, Q1, Q2)
    assert off < 1e-9
    assert u[0] == pytest.approx(0.0, abs=1e-12) and u[-1] == pytest.approx(1.0, abs=1e-12)
    d = Q2 - Q1
    across = qd - ((qd @ d) / (d @ d))[:, None] * d
    assert np.abs(across).max() < 1e-9


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
