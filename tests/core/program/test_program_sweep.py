"""Seeded random programs on the UR5 (LIN, CIRC and PTP mixed, random blend radii): the
invariants hold for every one, and a failure prints the seed that reproduces it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.errors import InputError, PlanningError
from core.program.plan import plan_program
from core.program.segments import ProgramTask, Segment
from robots import registry

UR5 = registry.get("ur5")
HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
T0 = UR5.fk(HOME)


def random_program(seed: int) -> tuple[Segment, ...]:
    rng = np.random.default_rng(seed)
    p = T0[:3, 3].copy()
    segs = []
    n = int(rng.integers(2, 6))
    for k in range(n):
        kind = rng.choice(["lin", "lin", "circ", "ptp"])
        step = rng.uniform(0.08, 0.2) * rng.choice([-1, 1], 3) * rng.uniform(0.3, 1.0, 3)
        step[2] *= 0.3
        goal = T0.copy()
        goal[:3, 3] = np.clip(p + step, T0[:3, 3] - 0.2, T0[:3, 3] + 0.2)
        r = 0.0 if k == n - 1 else float(rng.choice([0.0, 0.01, 0.02]))
        if kind == "ptp":
            q = HOME + rng.uniform(-0.3, 0.3, 6)
            segs.append(Segment("ptp", goal_positions=q, blend_radius=r))
            p = UR5.fk(q)[:3, 3]
            continue
        extra = {}
        if kind == "circ":
            mid = 0.5 * (p + goal[:3, 3])
            normal = np.cross(goal[:3, 3] - p, [0.0, 0.0, 1.0])
            extra["interim"] = mid + 0.3 * np.linalg.norm(goal[:3, 3] - p) * normal / max(
                np.linalg.norm(normal), 1e-9
            )
        segs.append(Segment(str(kind), goal_pose=goal, blend_radius=r, **extra))
        p = goal[:3, 3]
    return tuple(segs)


@pytest.mark.parametrize("seed", range(12))
def test_random_programs_keep_every_invariant(seed):
    segs = random_program(seed)
    try:
        res = plan_program(ProgramTask(UR5, HOME, segs, sample_period=0.005))
    except InputError:
        pytest.skip(f"seed {seed}: radii invalid for these lengths (validation, as documented)")
    except PlanningError as err:  # a random program may be infeasible: then it says where
        assert isinstance(err.extra.get("segment"), int), f"seed {seed}: {err!r}"
        return
    tr = res.trajectory
    msg = f"seed {seed}"
    assert np.all(np.diff(tr.times) > 0), msg
    assert np.all(np.abs(tr.velocities) <= UR5.velocity_limits * (1 + 1e-9)), msg
    assert np.all(np.abs(tr.accelerations) <= UR5.acceleration_limits * (1 + 1e-9)), msg
    assert np.all(tr.velocities[-1] == 0.0), msg
    h = np.diff(tr.times)
    jerk = np.abs(np.diff(tr.accelerations, axis=0)) / h[:, None]
    # q'' continuous but where the time-optimal law's s'' steps: between points < 1e-7 s apart
    assert jerk[h > 1e-7].max() < 5000.0, msg
    integral = 0.5 * (tr.accelerations[1:] + tr.accelerations[:-1]) * h[:, None]
    assert np.abs(np.diff(tr.velocities, axis=0) - integral).max() <= 1e-6, msg
    for info, seg in zip(res.segments, segs, strict=True):
        assert info.start_time <= info.end_time, msg
        if seg.type != "ptp" and not info.diagnostics.get("skipped"):
            assert info.diagnostics["max_position_deviation"] <= seg.position_tolerance, msg
            assert info.diagnostics["max_orientation_deviation"] <= seg.orientation_tolerance, msg
        if info.blend_out is None and info.index < len(segs) - 1:
            i = np.flatnonzero(tr.times == info.end_time)[0]
            assert np.all(tr.velocities[i] == 0.0), msg  # an unblended goal is a stop
