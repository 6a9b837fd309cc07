"""The geometry of each segment: its path, where blend spheres cut it, and its joint samples.

``SegmentPath`` is one planned segment: for LIN/CIRC the Cartesian path (a ``core.path.PATHS``
shape: ``lin`` is a ``line``, ``circ`` a ``circ``) and the joint path the segment's Cartesian method
planned along it (``core.program.build``); for PTP the joint straight line. ``s_in``/``s_out`` are
the path parameters where the tool leaves the incoming blend sphere and enters the outgoing one (0
and 1 without blends). The joint path between the planned samples is a C2 cubic spline in s, exact at
them (``joints``), so blends and cuts may fall anywhere.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline

from core.kinematics import Kinematics
from core.path import Path, build_path
from core.program.geometry.smooth import smooth_spline
from core.program.segments import Segment
from core.timing.joint_path import JointPath

PATH_KINDS = {"lin": "line", "circ": "circ"}
"""The ``core.path.PATHS`` shape of each Cartesian segment type."""
STEP_PER_TOLERANCE = 10.0
"""IK step along LIN/CIRC: this many position tolerances of travel (or orientation tolerances)."""
MIN_INTERVALS = 20
MAX_INTERVALS = 2000
PTP_STEP = 0.05
"""Joint step [rad] between samples of a PTP (its path is straight: samples only place blends)."""


def cartesian_path(
    seg: Segment, T_start: np.ndarray, T_goal: np.ndarray, task_space: str, index: int
) -> Path:
    """The LIN line or CIRC arc from ``T_start`` to ``T_goal`` (4, 4), from ``core.path.PATHS``;
    ``InputError`` at ``segments.index.*`` for bad circle geometry."""
    return build_path(
        PATH_KINDS[seg.type],
        T_start,
        T_goal,
        task_space,
        interim=seg.interim,
        center=seg.center,
        field=("segments", index),
    )


def intervals(seg: Segment, path: Path | None, dq: np.ndarray) -> int:
    """Sample intervals of a segment: a joint step of ``PTP_STEP`` (PTP), or ``STEP_PER_TOLERANCE``
    tolerances of tool travel (LIN/CIRC), between ``MIN_INTERVALS`` and ``MAX_INTERVALS``."""
    if path is None:
        return max(MIN_INTERVALS, int(np.ceil(np.abs(dq).max() / PTP_STEP)))
    n = max(
        path.length / (STEP_PER_TOLERANCE * seg.position_tolerance),
        path.angle / (STEP_PER_TOLERANCE * seg.orientation_tolerance),
    )
    return int(np.clip(np.ceil(n), MIN_INTERVALS, MAX_INTERVALS))


def sample_grid(n: int, s_in: float = 0.0, s_out: float = 1.0, blend: int = 40) -> np.ndarray:
    """Increasing path parameters from 0 to 1: ``n`` regular intervals, the blend cuts ``s_in``
    and ``s_out`` (where the tool leaves and enters the blend spheres), and about each cut a
    grading towards the spacing of the blend on its other side (its span over ``blend``
    intervals, doubling): so the joint spline through the samples meets a small blend without
    ringing (a 1e-9 m blend between two 10 cm lines left the spline 0.5 mm off the lines)."""
    regular = np.linspace(0.0, 1.0, n + 1)
    spacing = 1.0 / n
    cuts, graded = [], []
    for cut, width, side in ((s_in, s_in, 1.0), (s_out, 1.0 - s_out, -1.0)):
        if 0.0 < cut < 1.0:
            cuts.append(cut)
            step = width / blend
            while step < spacing / 2.0:
                graded.append(cut + side * step)
                step *= 2.0
    cuts_a = np.asarray(cuts + graded, dtype=float)
    cuts_a = cuts_a[(cuts_a > 0.0) & (cuts_a < 1.0)]
    # Regular points closer than a third of the spacing to a cut go (the cut stays): two samples
    # much closer than their neighbours would let the path spline between them wiggle.
    if len(cuts_a):
        near = np.min(np.abs(regular[:, None] - cuts_a[None, :]), axis=1) < spacing / 3
        regular = regular[~near | (regular == 0.0) | (regular == 1.0)]
    grid = np.unique(np.concatenate([regular, cuts_a]))
    keep = np.concatenate([[True], np.diff(grid) > 1e-12])
    return grid[keep]


@dataclass
class SegmentPath:
    """One segment's geometry and joint samples.

    Attributes:
        index: Position in the request's ``segments``.
        seg: The segment.
        path: Line or arc (LIN/CIRC), None for PTP.
        q_start: Joint positions at the start (dof,).
        s: Path parameters of the samples (K,), from 0 to 1 (or less for a partial plan).
        q: Joint positions at them (K, dof).
        s_in: Where the tool leaves the incoming blend sphere (0 without).
        s_out: Where it enters the outgoing blend sphere (1 without).
        blend_out: Whether the segment blends into the next.
        min_singular_value: Smallest singular value along the segment (LIN/CIRC).
        knot_count: IK knots of a bounded-deviation segment, None for the others.
        planned: The segment method's own joint samples ``(s, q)`` (LIN/CIRC), which ``joints``
            interpolates; None: ``(s, q)`` themselves.
        joint_path: A PTP's joint path found by a planner (``core.program.ptp_planned``: s in
            [0, 1] its share of the path's length), None: the straight joint segment.
        planner: How the planner found it (``PlannerReport.as_dict`` and ``path_length``), None.
    """

    index: int
    seg: Segment
    path: Path | None
    q_start: np.ndarray
    s: np.ndarray
    q: np.ndarray
    s_in: float = 0.0
    s_out: float = 1.0
    blend_out: bool = False
    min_singular_value: float = float("nan")
    knot_count: int | None = None
    planned: tuple[np.ndarray, np.ndarray] | None = None
    joint_path: JointPath | None = None
    planner: dict[str, object] | None = None
    _spline: CubicSpline | None = field(default=None, repr=False)

    @property
    def q_goal(self) -> np.ndarray:
        return self.q[-1]

    def joints(self, s: np.ndarray) -> np.ndarray:
        """Joint positions (N, dof) at ``s`` (N,): the joint line (PTP) or a C2 spline through the
        planned samples (LIN/CIRC; exact at them)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if self.joint_path is not None:
            return np.asarray(self.joint_path(s * self.joint_path.length), dtype=float)
        if self.path is None:
            return self.q[0] + s[:, None] * (self.q[-1] - self.q[0])
        if self._spline is None:
            s_k, q_k = self.planned if self.planned is not None else (self.s, self.q)
            self._spline = smooth_spline(s_k, q_k)
        return np.asarray(self._spline(s))

    def poses(self, robot: Kinematics, s: np.ndarray) -> np.ndarray:
        """Tool poses (N, 4, 4) at ``s``: the path's (LIN/CIRC) or FK of the joint line (PTP)."""
        if self.path is not None:
            return self.path.poses(s)
        return robot.fk_many(self.joints(s))

    def piece(self) -> tuple[np.ndarray, np.ndarray]:
        """The samples of the segment's own part, ``s_in <= s <= s_out``: (s, q)."""
        keep = (self.s >= self.s_in) & (self.s <= self.s_out)
        return self.s[keep], self.q[keep]
