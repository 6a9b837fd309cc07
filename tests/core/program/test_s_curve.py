"""S-curve stretches in programs: continuous path acceleration, tool jerk within its limit.

References: the robot's own Jacobian (pinocchio) for the tool velocity of the returned samples,
finite differences of it for the tool acceleration and jerk, and the same program's default
(trapezoidal) timing, whose tool jerk is far over the limit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.errors import InputError
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from robots import registry

UR5 = registry.get("ur5")
HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
T0 = UR5.fk(HOME)
JERK = 10.0
DT = 1e-3


def at(dx: float, dy: float, dz: float) -> np.ndarray:
    T = T0.copy()
    T[:3, 3] += [dx, dy, dz]
    return T


def program(profile: str) -> tuple[Segment, ...]:
    kw = {"speed_profile": profile, "max_linear_jerk": JERK}
    return (
        Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=0.02, **kw),
        Segment("circ", goal_pose=at(0.1, 0.1, 0), interim=at(0.13, 0.05, 0)[:3, 3], **kw),
    )


def tool_rates(result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tool acceleration and jerk by finite differences of J(q) q' over regular samples only
    (boundary points a few microseconds from a regular one would amplify rounding)."""
    tr = result.trajectory
    keep = np.concatenate([[True], np.diff(tr.times) > 0.5 * DT])
    t, q, qd = tr.times[keep], tr.positions[keep], tr.velocities[keep]
    v = np.einsum("nij,nj->ni", np.array([UR5.jacobian(x)[:3] for x in q]), qd)
    a = np.diff(v, axis=0) / np.diff(t)[:, None]
    jerk = np.linalg.norm(np.diff(a, axis=0), axis=1) / (0.5 * (t[2:] - t[:-2]))
    return t, a, jerk


@pytest.fixture(scope="module")
def both():
    return {p: plan_program(ProgramTask(UR5, HOME, program(p), sample_period=DT))
            for p in ("trapezoidal", "s_curve")}  # fmt: skip


def test_s_curve_keeps_the_tool_jerk_within_its_limit_and_the_acceleration_continuous(both):
    _, a, jerk = tool_rates(both["s_curve"])
    assert jerk.max() <= JERK * (1 + 1e-3)
    assert jerk.max() >= 0.9 * JERK  # the limit is what shapes the timing
    # Continuous path acceleration: no step between consecutive samples beyond jerk * dt.
    assert np.linalg.norm(np.diff(a, axis=0), axis=1).max() <= JERK * 2 * DT
    # The default timing of the same program is far over that jerk.
    assert tool_rates(both["trapezoidal"])[2].max() > 3 * JERK


def test_s_curve_still_holds_the_joint_limits_and_the_path(both):
    r = both["s_curve"]
    tr = r.trajectory
    # Velocities and accelerations are those of the positions (central differences, regular
    # samples only).
    t, q, qd, qdd = tr.times, tr.positions, tr.velocities, tr.accelerations
    reg = np.flatnonzero(
        (np.abs(np.diff(t)[:-1] - DT) < 1e-9) & (np.abs(np.diff(t)[1:] - DT) < 1e-9)
    )
    fd_v = (q[reg + 2] - q[reg]) / (2 * DT)
    fd_a = (qd[reg + 2] - qd[reg]) / (2 * DT)
    assert np.abs(fd_v - qd[reg + 1]).max() < 1e-5
    # (q'(t+h) - q'(t-h)) / 2h differs from q''(t) by at most h/2 times the peak jerk.
    assert np.all(np.abs(fd_a - qdd[reg + 1]) <= 0.5 * DT * tr.peak_jerk * (1 + 1e-6) + 1e-9)
    assert [sr.diagnostics["timing"] for sr in r.segments] == ["s_curve"] * 2
    assert [sr.diagnostics["timing"] for sr in both["trapezoidal"].segments] == ["time_optimal"] * 2
    assert np.all(np.abs(tr.velocities) <= UR5.velocity_limits * (1 + 1e-9))
    assert np.all(np.abs(tr.accelerations) <= UR5.acceleration_limits * (1 + 1e-9))
    assert r.diagnostics["max_position_deviation"] < 1e-6
    assert np.abs(tr.positions[-1] - both["trapezoidal"].trajectory.positions[-1]).max() < 1e-9
    assert np.abs(tr.velocities[[0, -1]]).max() == 0.0
    assert tr.duration > both["trapezoidal"].trajectory.duration


def test_bad_s_curve_inputs_are_validation_at_the_field():
    bad = (Segment("ptp", goal_positions=HOME + 0.1, speed_profile="s_curve"),)
    with pytest.raises(InputError) as e:
        plan_program(ProgramTask(UR5, HOME, bad))
    assert e.value.field == ("segments", 0, "speed_profile")
    bad = (Segment("lin", goal_pose=at(0.1, 0, 0), speed_profile="s_curve", max_linear_jerk=0.0),)
    with pytest.raises(InputError) as e:
        plan_program(ProgramTask(UR5, HOME, bad))
    assert e.value.field == ("segments", 0, "max_linear_jerk")
