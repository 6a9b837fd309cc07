"""Programs timed at the optimum (API.md "Programs timed at the optimum").

References independent of our law: toppra 0.6.10 (TOPP-RA) on the program's own blended joint
path under the same limits (its rows handed over as one linear constraint, ``bench.program_topp``)
for the duration; for the limits, the robot's published joint limits, and the tool's speed and
its rate of change measured from pinocchio's forward kinematics of the returned motion (the
quintic through consecutive returned points' q, q', q''; finite differences in time).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from scipy.interpolate import BPoly

from bench.program_topp import toppra_on_chunk
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from core.program.timed import timed_program
from robots import registry

UR5 = registry.get("ur5")
HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
T0 = UR5.fk(HOME)
DENSE = 8
"""Points checked between consecutive returned points."""


def at(dx: float, dy: float, dz: float = 0.0) -> np.ndarray:
    T = T0.copy()
    T[:3, 3] += [dx, dy, dz]
    return T


def rectangle(kind: str = "lin", r: float = 0.03) -> tuple[Segment, ...]:
    corners = [(0.15, 0.0), (0.15, 0.12), (0.0, 0.12), (0.0, 0.0)]
    return tuple(
        Segment(kind, goal_pose=at(x, y), blend_radius=r if k < 3 else 0.0)
        for k, (x, y) in enumerate(corners)
    )


def tool_positions(qs: np.ndarray) -> np.ndarray:
    """Tool positions ``(N, 3)`` by pinocchio directly."""
    model, data = UR5.model, UR5.model.createData()
    frame = model.getFrameId(UR5.tip_frame)
    out = []
    for q in qs:
        pin.framesForwardKinematics(model, data, q)
        out.append(data.oMf[frame].translation.copy())
    return np.array(out)


def between(tr) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t, q, q', q'' at the returned points and ``DENSE`` points between consecutive ones, from
    the quintic through their q, q', q''; an interval under 1e-7 s holds a step of the
    acceleration (bang-bang), which no polynomial follows: only its ends count (the returned
    values themselves), and one under 1e-4 s is left to them too (a quintic's second derivative
    over it is mostly rounding: 1e-16 rad over h^2)."""
    data = np.stack([tr.positions, tr.velocities, tr.accelerations], axis=1)
    poly = BPoly.from_derivatives(tr.times, data)
    f = np.arange(1, DENSE + 1) / (DENSE + 1)
    h = np.diff(tr.times)
    inner = (tr.times[:-1, None] + h[:, None] * f)[h > 1e-4].ravel()
    t = np.concatenate([inner, tr.times])
    order = np.argsort(t, kind="stable")
    q, qd, qdd = (np.concatenate([poly(inner, nu), x])[order]
                  for nu, x in enumerate((tr.positions, tr.velocities, tr.accelerations)))  # fmt: skip
    return t[order], q, qd, qdd


@pytest.fixture(scope="module", params=["lin", "ptp"])
def program(request):
    task = ProgramTask(UR5, HOME, rectangle(request.param), sample_period=0.005)
    return task, plan_program(task), timed_program(task)


def test_the_duration_is_within_2_percent_of_topp_ra_on_the_same_path_and_limits(program):
    _, result, timed = program
    ((_, timing, _),) = timed.timings  # the rectangle blends at every corner: one stretch
    path, rows = timing.path, timing.limits.rows
    fine = np.unique(np.concatenate([np.linspace(0.0, 1.0, 2001), path.breakpoints()]))
    reference, _ = toppra_on_chunk(path, rows, fine)
    ratio = result.trajectory.duration / reference.duration
    assert 0.98 <= ratio <= 1.02, ratio
    assert {s.diagnostics["timing"] for s in result.segments} == {"time_optimal"}


def test_the_limits_hold_at_the_points_and_between_them(program):
    _, result, _ = program
    tr = result.trajectory
    v_max, a_max = UR5.velocity_limits, UR5.acceleration_limits
    assert np.all(np.abs(tr.velocities) <= v_max * (1 + 1e-9))
    assert np.all(np.abs(tr.accelerations) <= a_max * (1 + 1e-9))
    _, _, qd, qdd = between(tr)
    assert np.all(np.abs(qd) <= v_max * (1 + 1e-6))
    assert np.all(np.abs(qdd) <= a_max * (1 + 1e-6))
    assert np.all(tr.peak_velocity <= v_max * (1 + 1e-9))
    assert np.all(tr.peak_acceleration <= a_max * (1 + 1e-9))


def test_lin_tool_speed_and_its_rate_of_change_stay_within_their_limits():
    """The tool's speed (|dp/dt| of pinocchio's tool positions) stays <= 0.25 m/s and its rate of
    change <= 1 m/s^2 (the LIN defaults), measured by finite differences in time; the speed limit
    binds (the motion is as fast as the tool allows on the straight parts)."""
    task = ProgramTask(UR5, HOME, rectangle("lin"), sample_period=0.005)
    tr = plan_program(task).trajectory
    t, q, _, _ = between(tr)
    t, keep = np.unique(t, return_index=True)
    wide = np.concatenate([[True], np.diff(t) > 1e-5])
    t, p = t[wide], tool_positions(q[keep][wide])
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(t)
    assert speed.max() <= 0.25 * (1 + 1e-4)
    assert speed.max() >= 0.25 * (1 - 1e-3)
    mid = 0.5 * (t[1:] + t[:-1])
    rate = np.abs(np.diff(speed)) / np.diff(mid)
    assert rate.max() <= 1.0 * (1 + 2e-2)


def test_every_acceleration_step_lies_between_two_close_points_and_every_switch_is_one():
    task = ProgramTask(UR5, HOME, rectangle("lin"), sample_period=0.01)
    timed = timed_program(task)
    tr = plan_program(task).trajectory
    ((offset, timing, _),) = timed.timings  # one stretch
    switches = offset + timing.switch_times()
    assert len(switches) > 10
    assert np.min(np.abs(tr.times[:, None] - switches[None, :]), axis=0).max() < 1e-12
    h = np.diff(tr.times)
    integral = 0.5 * (tr.accelerations[1:] + tr.accelerations[:-1]) * h[:, None]
    assert np.abs(np.diff(tr.velocities, axis=0) - integral).max() <= 1e-6
    jerk = np.abs(np.diff(tr.accelerations, axis=0)).max(axis=1) / h
    assert jerk[h > 1e-7].max() < 2000.0  # the acceleration steps only between close points
    assert jerk.max() > 1e5  # and it does step (bang-bang)


def test_a_lin_and_its_reverse_blended_stop_where_the_path_turns_back():
    """Down 8 cm and back up with a 2 cm blend: the blend goes straight down and up, so the
    motion stops at its bottom (the time-optimal law stops where the path turns back), on a grid
    of hundreds of intervals, not tens of thousands."""
    segs = (
        Segment("lin", goal_pose=at(0.0, 0.0, -0.08), blend_radius=0.02),
        Segment("lin", goal_pose=at(0.0, 0.0, 0.0)),
    )
    task = ProgramTask(UR5, HOME, segs, sample_period=0.005)
    result = plan_program(task)
    tr = result.trajectory
    ((_, timing, _),) = timed_program(task).timings  # one stretch
    assert len(timing.law.profile.switch_times) < 2000
    b0, b1 = result.segments[0].blend_out
    inside = (tr.times > b0) & (tr.times < b1)
    speeds = np.linalg.norm(tr.velocities[inside], axis=1)
    assert speeds.min() < 1e-9  # at rest at the bottom
    z = tool_positions(tr.positions)[:, 2]
    assert z.min() >= T0[2, 3] - 0.08 - 1e-6


@pytest.mark.parametrize("timing", ["jerk_limited", "time_optimal"])
def test_segments_say_which_timing_timed_them(timing):
    segs = (*rectangle("lin")[:2], replace(rectangle("lin")[2], speed_profile="s_curve"),
            rectangle("lin")[3])  # fmt: skip
    stops = tuple(replace(s, blend_radius=0.0) for s in segs[:2]) + segs[2:]
    result = plan_program(ProgramTask(UR5, HOME, stops, timing=timing))
    names = [s.diagnostics["timing"] for s in result.segments]
    assert names == [timing, timing, "s_curve", "s_curve"]


def test_time_optimal_is_faster_than_jerk_limited_on_the_same_program():
    task = ProgramTask(UR5, HOME, rectangle("ptp"))
    fast = plan_program(task).trajectory.duration
    smooth = plan_program(replace(task, timing="jerk_limited")).trajectory.duration
    assert fast < 0.9 * smooth
