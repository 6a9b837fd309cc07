"""Motion programs in the core: continuity, limits, paths outside blends, blends, stops, failures.

References are independent of the planner: the robot's own FK (pinocchio), closed-form lines and
circles, finite differences of the returned samples, and single-segment programs.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from core.errors import BranchFlip, Collision, InputError, JointLimit, Singularity, Unreachable
from core.path.arc import Arc
from core.program.assemble import rest_at
from core.program.build import build
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from core.program.timed import timed_program
from core.program.validate import layout
from robots import registry

UR5 = registry.get("ur5")
HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
T0 = UR5.fk(HOME)


def at(dx: float, dy: float, dz: float) -> np.ndarray:
    T = T0.copy()
    T[:3, 3] += [dx, dy, dz]
    return T


def mixed(r: float = 0.02) -> tuple[Segment, ...]:
    """LIN, LIN, CIRC, PTP, LIN: every kind of blend (LIN-LIN, LIN-CIRC, CIRC-PTP, PTP-LIN)."""
    return (
        Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=r),
        Segment("lin", goal_pose=at(0.1, 0.1, 0), blend_radius=r),
        Segment(
            "circ", goal_pose=at(0.0, 0.1, 0), interim=at(0.05, 0.13, 0)[:3, 3], blend_radius=r
        ),
        Segment("ptp", goal_positions=HOME + 0.1, blend_radius=r),
        Segment("lin", goal_pose=at(0, 0, 0)),
    )


@pytest.fixture(scope="module", params=["time_optimal", "jerk_limited"])
def planned(request):
    task = ProgramTask(UR5, HOME, mixed(), sample_period=0.002, timing=request.param)
    return task, plan_program(task)


def stopper(task):
    """``rest_at`` of the timed ``task``: (t, failure) -> the program brought to rest at t."""
    timed = timed_program(task)
    return lambda t, failure: rest_at(timed, t, failure)


def boundary_times(result) -> list[float]:
    return sorted(
        {t for s in result.segments for t in (s.start_time, s.end_time, *(s.blend_out or ()))}
    )


def test_boundaries_are_returned_points_and_the_program_ends_at_rest(planned):
    _, res = planned
    tr = res.trajectory
    for t in boundary_times(res):
        assert np.min(np.abs(tr.times - t)) == 0.0
    assert np.all(np.diff(tr.times) > 0)
    assert np.array_equal(tr.velocities[[0, -1]], np.zeros((2, 6)))
    assert np.array_equal(tr.accelerations[[0, -1]], np.zeros((2, 6)))
    assert [s.index for s in res.segments] == [0, 1, 2, 3, 4]
    assert all(s.blend_out is not None for s in res.segments[:4])


def test_velocity_and_acceleration_are_the_derivatives_and_continuous(planned):
    """q' and q'' agree with central differences of the samples everywhere, boundaries included:
    no jump in q, q' or q'' anywhere (a jump would break the differences at that point). The
    time-optimal timing's acceleration steps where s'' switches (bang-bang): each step lies
    between returned points 1e-8 s apart, so q'' is checked where both neighbouring intervals are
    wide (no step within them), and integrating q'' gives q' everywhere."""
    task, res = planned
    tr = res.trajectory
    t, q, qd, qdd = tr.times, tr.positions, tr.velocities, tr.accelerations
    h = np.diff(t)
    assert np.abs(np.diff(qd, axis=0) - 0.5 * (qdd[1:] + qdd[:-1]) * h[:, None]).max() < 1e-6
    h0, h1 = (t[1:-1] - t[:-2])[:, None], (t[2:] - t[1:-1])[:, None]

    def derivative(f):  # second-order on an uneven grid
        return (
            -h1 / (h0 * (h0 + h1)) * f[:-2]
            + (h1 - h0) / (h0 * h1) * f[1:-1]
            + h0 / (h1 * (h0 + h1)) * f[2:]
        )

    fd_v, fd_a = derivative(q), derivative(qd)
    wide = np.ones(len(t) - 2, dtype=bool)
    steps = np.ones(len(h), dtype=bool)
    if task.timing == "time_optimal":
        wide = (h[:-1] > 1e-7) & (h[1:] > 1e-7)
        steps = h > 1e-7
        assert (~wide).sum() > 0  # the steps are there, between close points
    # The jerk stays bounded (< 2000 rad/s^3 here): O(h) and O(h^2) slack at h = 2 ms.
    assert np.abs(fd_v - qd[1:-1])[wide].max() < 1e-3
    assert np.abs(fd_a - qdd[1:-1])[wide].max() < 0.5
    assert (np.abs(np.diff(qdd, axis=0)) / h[:, None])[steps].max() < 2000.0


def test_limits_hold_everywhere(planned):
    _, res = planned
    tr = res.trajectory
    assert np.all(np.abs(tr.velocities) <= UR5.velocity_limits * (1 + 1e-9))
    assert np.all(np.abs(tr.accelerations) <= UR5.acceleration_limits * (1 + 1e-9))
    lo, hi = UR5.position_limits.T
    assert np.all((tr.positions >= lo) & (tr.positions <= hi))


def test_lin_and_circ_stay_on_their_paths_outside_the_blends(planned):
    task, res = planned
    tr = res.trajectory
    T_start = [T0, at(0.1, 0, 0), at(0.1, 0.1, 0), None, UR5.fk(HOME + 0.1)]
    for seg, info, Ts in zip(task.segments, res.segments, T_start, strict=True):
        sel = (tr.times >= info.start_time) & (tr.times <= info.end_time)
        T = UR5.fk_many(tr.positions[sel])
        assert sel.sum() > 10
        if seg.type == "lin":
            p0, p1 = Ts[:3, 3], seg.goal_pose[:3, 3]
            d = (p1 - p0) / np.linalg.norm(p1 - p0)
            rel = T[:, :3, 3] - p0
            off = rel - np.outer(rel @ d, d)
            assert np.linalg.norm(off, axis=1).max() < 1e-6
            # Orientation: slerp (scipy's) at the point's own place along the line.
            key = Rotation.from_matrix(np.stack([Ts[:3, :3], seg.goal_pose[:3, :3]]))
            ref = Slerp([0.0, 1.0], key)(np.clip(rel @ d / np.linalg.norm(p1 - p0), 0, 1))
            err = (ref.inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()
            assert err.max() < 1e-6
        elif seg.type == "circ":
            arc = Arc(Ts, seg.goal_pose, interim=seg.interim)
            radius = np.linalg.norm(T[:, :3, 3] - arc.center, axis=1)
            assert np.abs(radius - arc.radius).max() < 1e-6
            assert np.abs((T[:, :3, 3] - arc.center) @ arc.normal).max() < 1e-6


def test_the_tool_passes_within_the_radius_of_each_corner_and_never_stops(planned):
    _, res = planned
    tr = res.trajectory
    corners = [at(0.1, 0, 0), at(0.1, 0.1, 0), at(0.0, 0.1, 0), UR5.fk(HOME + 0.1)]
    for info, corner in zip(res.segments[:4], corners, strict=True):
        b0, b1 = info.blend_out
        sel = (tr.times >= b0) & (tr.times <= b1)
        p = UR5.fk_many(tr.positions[sel])[:, :3, 3]
        dist = np.linalg.norm(p - corner[:3, 3], axis=1)
        assert dist.max() <= 0.02 + 1e-9  # inside the sphere, entering and leaving at r
        assert dist[0] == pytest.approx(0.02, abs=1e-6)
        assert dist[-1] == pytest.approx(0.02, abs=1e-6)
        assert np.linalg.norm(tr.velocities[sel], axis=1).min() > 0.05


def test_a_sharp_corner_slows_down_more_than_a_shallow_one():
    def corner_speed(turn: float) -> float:
        p1 = at(0.1, 0, 0)
        p2 = at(0.1 + 0.1 * math.cos(turn), 0.1 * math.sin(turn), 0)
        segs = (Segment("lin", goal_pose=p1, blend_radius=0.03), Segment("lin", goal_pose=p2))
        res = plan_program(ProgramTask(UR5, HOME, segs, sample_period=0.002))
        tr = res.trajectory
        b0, b1 = res.segments[0].blend_out
        sel = (tr.times >= b0) & (tr.times <= b1)
        p = UR5.fk_many(tr.positions[sel])[:, :3, 3]
        return float(np.min(np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(tr.times[sel])))

    shallow, sharp = corner_speed(0.2), corner_speed(2.5)
    assert shallow > 0.24  # a shallow corner barely slows from 0.25 m/s
    assert sharp < 0.8 * shallow


def test_without_blends_the_program_equals_the_single_moves():
    segs = tuple(
        Segment(s.type, goal_pose=s.goal_pose, goal_positions=s.goal_positions, interim=s.interim)
        for s in mixed()
    )
    whole = ProgramTask(UR5, HOME, segs)
    geo = build(whole, layout(whole))
    res = plan_program(whole)
    q = HOME
    for k, seg in enumerate(segs):
        alone_task = ProgramTask(UR5, q, (seg,))
        alone = build(alone_task, layout(alone_task)).segments[0]
        part = geo.segments[k]
        assert np.abs(part.q - alone.q).max() <= 1e-9
        assert np.abs(part.s - alone.s).max() <= 1e-12
        info = plan_program(alone_task).segments[0]
        mine = res.segments[k]
        assert mine.end_time - mine.start_time == pytest.approx(info.end_time, abs=1e-9)
        i = np.flatnonzero(res.trajectory.times == mine.end_time)[0]
        assert np.abs(res.trajectory.positions[i] - alone.q[-1]).max() <= 1e-9
        assert np.abs(res.trajectory.velocities[i]).max() == 0.0  # stops at every goal
        q = alone.q[-1]


@pytest.mark.parametrize(
    ("segments", "field"),
    [
        ((Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=0.06), Segment("lin", goal_pose=at(0.1, 0.2, 0))), ("segments", 0, "blend_radius")),
        ((Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=0.045), Segment("circ", goal_pose=at(0.1, 0.09, 0), interim=at(0.145, 0.045, 0)[:3, 3], blend_radius=0.05), Segment("lin", goal_pose=at(0.0, 0.09, 0))), ("segments", 1, "blend_radius")),
        ((Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=0.01),), ("segments", 0, "blend_radius")),
        ((Segment("circ", goal_pose=at(0.2, 0, 0), interim=at(0.1, 0, 0)[:3, 3]),), ("segments", 0, "interim")),
        ((Segment("circ", goal_pose=at(0.2, 0, 0), center=at(0.1, 0.01, 0)[:3, 3] + [0.001, 0, 0]),), ("segments", 0, "center")),
        ((Segment("lin", goal_pose=at(0.1, 0, 0), velocity_scale=0.0),), ("segments", 0, "velocity_scale")),
        ((), ("segments",)),
        (tuple(Segment("lin", goal_pose=at(0.01 * (k % 2), 0, 0)) for k in range(101)), ("segments",)),
    ],
)  # fmt: skip
def test_validation_errors_name_the_field(segments, field):
    with pytest.raises(InputError) as err:
        plan_program(ProgramTask(UR5, HOME, segments))
    assert err.value.field == field


def test_zero_length_segments_are_skipped_with_a_warning():
    segs = (
        Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=0.02),
        Segment("lin", goal_pose=at(0.1, 0, 0), blend_radius=0.02),
        Segment("lin", goal_pose=at(0.1, 0.1, 0)),
    )
    res = plan_program(ProgramTask(UR5, HOME, segs))
    assert res.segments[1].diagnostics["skipped"]
    assert any("segment 1" in w for w in res.warnings)
    assert res.segments[0].blend_out is not None  # blends over the skipped one into segment 2


def test_unreachable_lin_names_its_segment_and_s():
    segs = (Segment("ptp", goal_positions=HOME + 0.05), Segment("lin", goal_pose=at(-1.0, 0, 0)))
    with pytest.raises(Unreachable) as err:
        plan_program(ProgramTask(UR5, HOME, segs))
    assert err.value.extra["segment"] == 1
    assert 0.0 < err.value.s < 1.0
    part = plan_program(ProgramTask(UR5, HOME, segs, allow_partial=True))
    assert part.failure is not None and part.failure.extra["segment"] == 1
    assert 0.5 < part.fraction < 1.0
    tr = part.trajectory
    assert np.array_equal(tr.velocities[-1], np.zeros(6))
    # The partial line is on its line up to where it stops.
    p = UR5.fk(tr.positions[-1])[:3, 3]
    start = UR5.fk(HOME + 0.05)[:3, 3]
    d = at(-1.0, 0, 0)[:3, 3] - start
    off = (p - start) - ((p - start) @ d) / (d @ d) * d
    assert np.linalg.norm(off) < 1e-6


def test_singular_lin_names_its_segment():
    puma = registry.get("puma560")
    q2, q3 = math.pi / 4, -math.pi
    q0 = np.array([0.0, q2, q3, 0.0, 0.6, 0.0])
    segs = (
        Segment("ptp", goal_positions=np.array([0.0, q2, q3, 0.0, 0.3, 0.0])),
        Segment("lin", goal_positions=np.array([0.0, q2, q3, 0.0, -0.3, 0.0])),
    )
    with pytest.raises((Singularity, BranchFlip)) as err:
        plan_program(ProgramTask(puma, q0, segs))
    assert err.value.extra["segment"] == 1
    assert 0.0 < err.value.s < 1.0


def test_ptp_goal_outside_limits_and_configuration_label_are_validation():
    bad = HOME.copy()
    bad[0] = 10.0
    with pytest.raises(InputError) as err:
        plan_program(ProgramTask(UR5, HOME, (Segment("ptp", goal_positions=bad),)))
    assert err.value.field == ("segments", 0, "goal", "positions")
    if not hasattr(UR5, "configuration"):
        with pytest.raises(InputError) as err:
            plan_program(
                ProgramTask(
                    UR5, HOME, (Segment("ptp", goal_pose=at(0.1, 0, 0), configuration="x"),)
                )
            )
        assert err.value.field == ("segments", 0, "goal", "configuration")


def test_lin_past_a_joint_limit_names_its_segment_and_s():
    q0 = HOME.copy()
    q0[5] = 2 * np.pi - 0.1  # wrist 3 0.1 rad short of its limit
    T = UR5.fk(q0)
    turn = T.copy()
    turn[:3, :3] = T[:3, :3] @ Rotation.from_rotvec([0, 0, 0.3]).as_matrix()
    q_start = q0 - [0, 0, 0, 0, 0, 0.05]
    segs = (Segment("ptp", goal_positions=q0), Segment("lin", goal_pose=turn))
    with pytest.raises(JointLimit) as err:
        plan_program(ProgramTask(UR5, q_start, segs))
    assert err.value.extra["segment"] == 1
    assert err.value.joint == 5
    # The wrist reaches its limit after 0.1 of the 0.3 rad turn.
    assert err.value.s == pytest.approx(1 / 3, abs=1e-3)


@pytest.mark.parametrize("timing", ["time_optimal", "jerk_limited"])
def test_circ_circ_and_ptp_ptp_blends_are_smooth_and_inside_their_spheres(timing):
    """Limits, spheres and arcs under both timings; the jerk is bounded under ``jerk_limited``
    (the time-optimal law's acceleration steps where s'' switches: bounded between the steps)."""
    segs = (
        Segment("circ", goal_pose=at(0.1, 0.1, 0), center=at(0.1, 0, 0)[:3, 3], blend_radius=0.03),
        Segment("circ", goal_pose=at(0.2, 0.2, 0), interim=at(0.13, 0.17, 0)[:3, 3], blend_radius=0.03),
        Segment("ptp", goal_positions=HOME + 0.2, blend_radius=0.05),
        Segment("ptp", goal_positions=HOME - 0.1),
    )  # fmt: skip
    res = plan_program(ProgramTask(UR5, HOME, segs, sample_period=0.002, timing=timing))
    tr = res.trajectory
    assert np.all(np.abs(tr.velocities) <= UR5.velocity_limits * (1 + 1e-9))
    assert np.all(np.abs(tr.accelerations) <= UR5.acceleration_limits * (1 + 1e-9))
    h = np.diff(tr.times)
    wide = h > 1e-7 if timing == "time_optimal" else h > 0
    assert (np.abs(np.diff(tr.accelerations, axis=0)) / h[:, None])[wide].max() < 2000.0
    corners = [at(0.1, 0.1, 0), at(0.2, 0.2, 0), UR5.fk(HOME + 0.2)]
    for info, corner, r in zip(res.segments[:3], corners, (0.03, 0.03, 0.05), strict=True):
        b0, b1 = info.blend_out
        sel = (tr.times >= b0) & (tr.times <= b1)
        dist = np.linalg.norm(UR5.fk_many(tr.positions[sel])[:, :3, 3] - corner[:3, 3], axis=1)
        assert dist.max() <= r + 1e-9
        assert np.linalg.norm(tr.velocities[sel], axis=1).min() > 0.05
    for k in (0, 1):  # both arcs on their circles outside the blends
        info = res.segments[k]
        sel = (tr.times >= info.start_time) & (tr.times <= info.end_time)
        p = UR5.fk_many(tr.positions[sel])[:, :3, 3]
        start = T0 if k == 0 else at(0.1, 0.1, 0)
        seg = segs[k]
        arc = Arc(start, seg.goal_pose, center=seg.center, interim=seg.interim)
        assert np.abs(np.linalg.norm(p - arc.center, axis=1) - arc.radius).max() < 1e-6


def test_lin_and_circ_keep_the_configuration_label_of_their_start():
    result = plan_program(ProgramTask(UR5, HOME, mixed()))
    labels = set(UR5.configurations(result.trajectory.positions))
    assert labels == {UR5.configuration(HOME)}


def test_peak_jerk_is_the_analytic_jerk_checked_by_finite_differences():
    result = plan_program(ProgramTask(UR5, HOME, mixed(), sample_period=2e-4))
    tr = result.trajectory
    fd = np.abs(np.diff(tr.accelerations, axis=0) / np.diff(tr.times)[:, None]).max(axis=0)
    peak = tr.peak_jerk
    assert np.all(np.isfinite(peak))
    # Finite differences average the jerk over an interval: never above the analytic peak, and
    # at this sampling close to it.
    assert np.all(fd <= peak * (1 + 1e-3) + 1e-9)
    assert np.all(fd >= 0.8 * peak)
    assert np.all(tr.peak_velocity >= np.abs(tr.velocities).max(axis=0))


def test_zero_length_segments_at_the_end_are_listed_too():
    """Was: left out of ``segments`` (only skipped ones between moves were listed). Every requested
    segment is listed: a zero-length one at the end starts and ends with the answer, with a
    warning; so is a segment that moves no joint although ``layout`` could not tell (a PTP to the
    joints a LIN ended at)."""
    segs = (
        Segment("lin", goal_pose=at(0.1, 0, 0)),
        Segment("lin", goal_pose=at(0.1, 0, 0)),
        Segment("ptp", goal_pose=at(0.1, 0, 0)),
    )
    res = plan_program(ProgramTask(UR5, HOME, segs))
    end = float(res.trajectory.times[-1])
    assert [s.index for s in res.segments] == [0, 1, 2]
    assert res.segments[0].end_time == end
    for s in res.segments[1:]:
        assert s.start_time == s.end_time == end and s.blend_out is None
        assert s.diagnostics["skipped"]
        assert any(w.startswith(f"segment {s.index} has zero length") for w in res.warnings)
    q_end = res.trajectory.positions[-1]
    still = (Segment("lin", goal_pose=at(0.1, 0, 0)), Segment("ptp", goal_positions=q_end))
    res = plan_program(ProgramTask(UR5, HOME, still))
    last = res.segments[-1]
    assert [s.index for s in res.segments] == [0, 1]
    assert last.start_time == last.end_time == res.trajectory.times[-1]
    assert last.diagnostics["skipped"]
    assert any(w.startswith("segment 1 has zero length") for w in res.warnings)


@pytest.mark.parametrize("share", [0.2, 0.5, 0.85])
def test_rest_at_brings_the_program_to_rest_where_it_was_on_its_path(planned, share):
    """``rest_at(t)`` (a collision ahead of t with ``allow_partial``): the blended program (one
    chunk) re-timed to stop at the point it reached at t, within the limits, every LIN/CIRC still
    on its path outside the blends, the segments listed up to the one it stops in."""
    task, res = planned
    tr = res.trajectory
    k = int(share * (len(tr.times) - 1))
    failure = Collision("a contact ahead")
    cut = stopper(task)(float(tr.times[k]), failure)
    out = cut.trajectory
    np.testing.assert_allclose(out.positions[-1], tr.positions[k], atol=1e-12)
    np.testing.assert_allclose(out.positions[0], HOME, atol=1e-12)
    assert np.array_equal(out.velocities[[0, -1]], np.zeros((2, 6)))
    assert np.array_equal(out.accelerations[[0, -1]], np.zeros((2, 6)))
    assert np.all(out.peak_velocity <= UR5.velocity_limits * (1 + 1e-9))
    assert np.all(out.peak_acceleration <= UR5.acceleration_limits * (1 + 1e-9))
    assert cut.failure is failure and cut.warnings[0].startswith("planned ")
    assert not any("strays" in w for w in cut.warnings)
    assert cut.diagnostics["max_position_deviation"] < 1e-3
    # The segment it stops in is the one the plan was in at t; its window ends with the answer.
    owner = max(s.index for s in res.segments if s.start_time <= tr.times[k])
    assert cut.segments[-1].index == owner
    last = cut.segments[-1]
    assert (last.blend_out[1] if last.blend_out else last.end_time) == out.times[-1]
    assert owner / 5 <= cut.fraction <= (owner + 1) / 5


def test_rest_at_keeps_the_stretches_before_the_cut_as_planned():
    """Two unblended LINs (two rest-to-rest stretches) cut in the second: the first is returned
    exactly as planned; a cut at the stop between them is the first stretch alone."""
    segs = (Segment("lin", goal_pose=at(0.1, 0, 0)), Segment("lin", goal_pose=at(0.1, 0.1, 0)))
    task = ProgramTask(UR5, HOME, segs, sample_period=0.004)
    res = plan_program(task)
    stop_at = stopper(task)
    tr = res.trajectory
    stop = res.segments[0].end_time
    n = int(np.searchsorted(tr.times, stop)) + 1
    t_cut = 0.5 * (stop + tr.times[-1])
    cut = stop_at(t_cut, Collision("ahead"))
    np.testing.assert_array_equal(cut.trajectory.positions[:n], tr.positions[:n])
    np.testing.assert_array_equal(cut.trajectory.times[:n], tr.times[:n])
    assert cut.trajectory.velocities[-1].tolist() == [0.0] * 6
    p = UR5.fk(cut.trajectory.positions[-1])[:3, 3] - at(0.1, 0, 0)[:3, 3]
    assert abs(p[0]) < 1e-6 and abs(p[2]) < 1e-6 and 0.0 < p[1] < 0.1
    assert cut.fraction == pytest.approx((1 + p[1] / 0.1) / 2, abs=1e-4)
    at_stop = stop_at(stop, Collision("ahead"))
    mine = at_stop.trajectory
    assert mine.times[-1] == stop
    common, a, b = np.intersect1d(mine.times, tr.times, return_indices=True)
    assert len(common) >= len(mine.times) - 2  # the last regular interval may be merged
    np.testing.assert_array_equal(mine.positions[a], tr.positions[b])
    assert at_stop.fraction == 0.5 and [s.index for s in at_stop.segments] == [0]
    assert stop_at(0.0, Collision("ahead")) is None


def test_a_lin_segment_is_the_cartesian_line_planned_by_its_method():
    """Issue 23: a program LIN is the Cartesian task on its line, planned by its method: its
    joint samples are exactly the points a Cartesian request with the same ``samples`` returns
    (was a second IK walk: deviation 1.4e-6 m against 1.1e-8 m for the same line)."""
    from core.cartesian.plan import plan
    from core.cartesian.task import CartesianTask
    from core.program.build import segment_task
    from core.program.geometry.paths import cartesian_path, intervals

    seg = Segment("lin", goal_pose=at(0.1, 0.05, 0.0))
    task = ProgramTask(UR5, HOME, (seg,))
    part = build(task, layout(task)).segments[0]
    n = intervals(seg, cartesian_path(seg, T0, seg.goal_pose, "pose", 0), np.zeros(0))
    line = CartesianTask(UR5, HOME, seg.goal_pose, samples=n + 1)
    alone = plan(line, "sampled").trajectory.positions
    assert segment_task(task, seg, HOME, seg.goal_pose, n).samples == n + 1
    np.testing.assert_array_equal(part.planned[1], alone)
    np.testing.assert_allclose(part.planned[0], np.linspace(0.0, 1.0, n + 1), atol=1e-9)
