"""The program's answer: per-segment times and diagnostics, deviation measured densely.

LIN/CIRC segments are measured against their line/arc outside the blend windows, along the
returned trajectory with ``CHECKS`` checks between consecutive returned points (FK of the
returned motion, not of the IK samples); over the tolerance is 422 ``infeasible`` at the segment.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from core.collisions import ClearanceReport
from core.errors import Infeasible, PlanningError
from core.program.build import Geometry
from core.program.geometry.paths import SegmentPath
from core.program.segments import ProgramTask
from core.program.validate import Layout
from core.trajectory import Trajectory

CHECKS = 10
"""Deviation checks between consecutive returned points (as for single lines)."""
GOAL_BRANCH_WARNING = 1e-3
"""A LIN/CIRC ending farther than this [rad] from its goal.positions gets a warning."""
TOLERANCE_SLACK = 1e-6
"""Relative slack of the tolerance check (rounding of the dense measurement)."""


@dataclass(frozen=True)
class SegmentResult:
    """One segment's part of the program.

    Attributes:
        index: Position in the request's ``segments``.
        type: ``ptp``, ``lin`` or ``circ``.
        start_time: When the segment's own part begins [s] (after the incoming blend).
        end_time: When it ends [s] (at its goal, or where the outgoing blend begins).
        blend_out: (start, end) [s] of the blend into the next segment, or None.
        diagnostics: Per-segment facts (deviation, singular values, skipped, ...).
    """

    index: int
    type: str
    start_time: float
    end_time: float
    blend_out: tuple[float, float] | None
    diagnostics: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ProgramResult:
    """The timed program.

    Attributes:
        trajectory: The returned points.
        segments: One entry per requested segment, in order: skipped (zero-length) ones too, with
            ``start_time == end_time`` (a partial plan: up to the failing segment).
        warnings: Skipped segments, ignored radii, partial plans, deviations over tolerance.
        fraction: Share of the segments planned (1.0 unless partial).
        failure: What stopped a partial plan, else None.
        diagnostics: Program-wide facts (max deviations, stretch, chunk count).
        clearance: How close the motion comes to contact (``core.collisions``), None when nothing
            is checked.
    """

    trajectory: Trajectory
    segments: tuple[SegmentResult, ...]
    warnings: tuple[str, ...]
    fraction: float
    failure: PlanningError | None
    diagnostics: dict[str, Any]
    clearance: ClearanceReport | None = None


def _dense(times: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """``CHECKS`` times per interval of the returned ``times`` within [t0, t1]."""
    inside = times[(times >= t0 - 1e-12) & (times <= t1 + 1e-12)]
    grid = np.unique(np.concatenate([[t0], inside, [t1]]))
    frac = np.arange(CHECKS) / CHECKS
    return np.concatenate([(grid[:-1, None] + np.diff(grid)[:, None] * frac).ravel(), [t1]])


def _measured(
    task: ProgramTask,
    sp: SegmentPath,
    traj: Trajectory,
    sampler: Callable[[np.ndarray], np.ndarray],
    window: tuple[float, float],
) -> dict[str, Any]:
    """A LIN/CIRC segment's own part measured against its path (``CHECKS`` per returned interval
    of the returned motion): its diagnostics; ``Infeasible`` at the segment and its ``s`` where it
    strays over its tolerance (the contract: outside the blend spheres every LIN/CIRC stays on its
    line within tolerance)."""
    seg, path = sp.seg, sp.path
    assert path is not None
    dense = _dense(traj.times, *window)
    dev = path.deviation(
        task.robot.fk_many(sampler(dense)), seg.position_tolerance, seg.orientation_tolerance
    )
    dp, do = float(dev.position.max()), float(dev.orientation.max())
    ratio = np.maximum(
        dev.position / seg.position_tolerance, dev.orientation / seg.orientation_tolerance
    )
    if ratio.max() > 1.0 + TOLERANCE_SLACK:
        k = int(np.argmax(ratio))
        raise Infeasible(
            f"segment {sp.index} strays up to {dp:.3g} m / {do:.3g} rad from its path between "
            f"returned points, over its tolerance: give a larger tolerance or more samples",
            s=float(dev.s[k]),
            extra={
                "segment": sp.index,
                "max_position_deviation": dp,
                "max_orientation_deviation": do,
            },
        )
    diag: dict[str, Any] = {
        "max_position_deviation": dp,
        "max_orientation_deviation": do,
        "min_singular_value": sp.min_singular_value,
        "length": path.length,
        "method": seg.method,
    }
    if sp.knot_count is not None:
        diag["knot_count"] = sp.knot_count
    return diag


def report(
    task: ProgramTask,
    lay: Layout,
    geo: Geometry,
    spans: dict[tuple[int, bool], tuple[float, float]],
    traj: Trajectory,
    sampler: Callable[[np.ndarray], np.ndarray],
) -> ProgramResult:
    """Assemble the ``ProgramResult`` (``spans``: (segment, is_blend) -> (start, end) [s])."""
    warnings = list(lay.warnings)
    planned = {sp.index: sp for sp in geo.segments}
    last_planned = max(planned)
    results: list[SegmentResult] = []
    worst_p, worst_o, sigma = 0.0, 0.0, np.inf
    t_prev = 0.0
    for i, seg in enumerate(task.segments):
        if geo.failure is not None and i > last_planned:  # a partial plan: not reached
            break
        if i not in planned or (i, False) not in spans:
            # zero length (``layout``'s), or planned yet no joint moves (nothing was timed)
            if i in planned and not any(w.startswith(f"segment {i} has zero") for w in warnings):
                warnings.append(f"segment {i} has zero length (no joint moves): skipped")
            results.append(SegmentResult(i, seg.type, t_prev, t_prev, None, {"skipped": True}))
            continue
        sp = planned[i]
        t0, t1 = spans[(i, False)]
        blend = spans.get((i, True))
        diag: dict[str, Any] = {
            "skipped": False,
            "duration": t1 - t0 + (blend[1] - blend[0] if blend else 0.0),
        }
        if sp.planner is not None:  # a PTP found by the collision-free planner
            diag["planner"] = sp.planner
        if sp.path is not None and t1 > t0:
            diag.update(_measured(task, sp, traj, sampler, (t0, t1)))
            worst_p = max(worst_p, diag["max_position_deviation"])
            worst_o = max(worst_o, diag["max_orientation_deviation"])
            sigma = min(sigma, sp.min_singular_value)
        if sp.path is not None and seg.goal_positions is not None and sp.s[-1] == 1.0:
            gap = float(np.abs(sp.q_goal - seg.goal_positions).max())
            if gap > GOAL_BRANCH_WARNING:
                warnings.append(
                    f"segment {i} ends at its goal pose in another joint configuration than "
                    f"goal.positions (up to {gap:.3g} rad apart): the path leads there without a "
                    "branch flip"
                )
        results.append(SegmentResult(i, seg.type, t0, t1, blend, diag))
        t_prev = blend[1] if blend else t1
    fraction = 1.0
    if geo.failure is not None and geo.failed_segment is not None:
        n = len(task.segments)
        # the segments before the failing one, plus the share of it that is returned (none of a
        # PTP or of a segment whose start already fails; a LIN/CIRC up to where it got)
        failed = planned.get(geo.failed_segment)
        share = 0.0
        if failed is not None and failed.s is not None and len(failed.s):
            share = min(max(float(failed.s[-1]), 0.0), 1.0)
        fraction = (geo.failed_segment + share) / n
        warnings.insert(0, f"planned {fraction:.1%} of the program: {geo.failure.detail}")
    diagnostics = {
        "max_position_deviation": worst_p,
        "max_orientation_deviation": worst_o,
        "min_singular_value": float(sigma) if np.isfinite(sigma) else None,
    }
    return ProgramResult(traj, tuple(results), tuple(warnings), fraction, geo.failure, diagnostics)
