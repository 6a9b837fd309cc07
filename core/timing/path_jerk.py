"""Jerk-limited timing along a joint path: the time-optimal s(t), filtered, slowed where needed.

``jerk_limited(path, limits, jerk)`` times a C2 joint path (a spline: d3q/ds3 bounded, ``path(s,
3)``) from rest to rest within ``limits`` (``PathLimits``: joint velocity and acceleration, tool
speed, effort) and joint jerk limits |q'''| <= ``jerk``, with q'' continuous, where

    q''' = q_s s''' + 3 q_ss s' s'' + q_sss s'^3.

1. The time-optimal s(t) (``core.timing.topp``) has s'' constant between grid times.
2. Its moving average over ``FILTER`` * max_j(a_j / J_j) seconds (``core.timing.box_filter``)
   has s'' continuous and |s'''| at most the swing of s'' over that width: 2 a / J is the time a
   joint's acceleration takes from -a to +a at its jerk limit, so the q_s s''' part stays about
   within the limit.
3. A dense check of every limit along the filtered motion gives the speed factor each checked
   instant needs (velocity over its limit, the square root of acceleration and effort's, the cube
   root of jerk's). Where one is above 1, the path speed is capped (``core.timing.speed_cap``)
   at s' / factor over the stretch of path that instant's filter window covered, and steps 1-2 run
   again (at most ``ROUNDS`` times): the jerk terms in s' fall where the path bends sharply
   (large d3q/ds3) without slowing the rest.
4. What remains above the limits is found exactly (samples on every smooth piece, peaks refined)
   and the whole motion is slowed uniformly by it (``Stretched``: s' / k, s'' / k^2, s''' / k^3;
   effort with its gravity part held), so every limit holds (to the peaks' precision, ~1e-13).

The answer (``JerkLimited``) samples q, q', q'', q''' exactly; its duration is at least the
time-optimal one (``time_optimal_duration``).
"""

from __future__ import annotations

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.timing.box_filter import BoxFiltered
from core.timing.interval_peaks import refine_peaks, sampled_peaks
from core.timing.joint_path import JoinedPath, JointPath
from core.timing.path_constraints import PathLimits
from core.timing.path_profile import PathLaw, Stretched, joint_motion
from core.timing.speed_cap import CappedPath, capped_limits
from core.timing.topp import Binding, TimeOptimal, time_optimal

OPEN = 1e3
"""The cap where none is needed, over the largest time-optimal speed (it never binds)."""
FILTER = 2.0
"""Filter width over the largest a_j / J_j."""
SHORTEST = 1e-3
"""Filter width over the time-optimal duration where no joint has both limits finite."""
ROUNDS = 8
"""Most rounds of capping the speed (step 3)."""
SETTLED = 1e-3
"""Capping stops once no checked instant needs the speed lower by more than this (relative)."""
MARGIN = 0.98
"""A new cap is this share of the speed the check asked for (the filter spreads a change)."""
CHECKS = 4
"""Intervals of samples per smooth piece in the capping check (step 3)."""
PIECE_SAMPLES = 8
"""Intervals of samples per smooth piece in the final check (step 4)."""
NEAR = 1e-6
"""Final check: sampled peaks within this (relative) of the largest are found exactly."""
AIM = 1e-12
"""The final slow-down's relative margin over the largest factor found."""
NUDGE = 1e-9
"""Final check: a piece's end samples sit this share of the piece inside it (the jerk steps at
its ends)."""


class JerkLimited:
    """The jerk-limited s(t) along ``path``: ``law`` (a ``PathLaw``), sampled as q(s(t)).

    Attributes:
        duration: [s].
        time_optimal_duration: [s] of the time-optimal timing of the same path and limits.
        stretch: The final uniform slow-down (>= 1).
        binding: Which limit binds where in the capped time-optimal law (``"jerk"`` where the
            speed cap does).
        switch_times: ``[0, duration]``: s'' never jumps.
        profile: The capped time-optimal s(t) that was filtered (its grid ``profile.s``).
        peak_jerk: Largest |q'''| per joint ``(dof,)`` found by the final check.
    """

    def __init__(self, path: JointPath, law: PathLaw, optimal: TimeOptimal, timing: TimeOptimal,
                 stretch: float, peak_jerk: np.ndarray) -> None:  # fmt: skip
        self.path, self.law, self.stretch = path, law, stretch
        self.duration = float(law.duration)
        self.time_optimal_duration = optimal.duration
        self.binding = timing.binding if timing is optimal else _named(timing.binding, path.dof)
        self.switch_times = np.array([0.0, self.duration])
        self.profile = timing.profile
        self.peak_jerk = peak_jerk

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s, s', s'', s''' at times ``t`` [s]."""
        return np.asarray(self.law(np.asarray(t, dtype=float), order))

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q', q'' at times ``t`` ``(K,)``, each ``(K, dof)`` (exact derivatives)."""
        q, qd, qdd = joint_motion(self.path, self.law, t)
        return q, qd, qdd

    def sample_jerk(self, t: np.ndarray) -> np.ndarray:
        """q''' at times ``t`` ``(K, dof)`` (exact)."""
        return joint_motion(self.path, self.law, t, jerk=True)[3]


def jerk_limited(
    path: JointPath,
    limits: PathLimits,
    jerk: np.ndarray,
    *,
    joint_names: tuple[str, ...] = (),
    deadline: Deadline = NO_DEADLINE,
) -> JerkLimited:
    """The jerk-limited rest-to-rest timing of ``path`` (order 3 derivatives needed) within
    ``limits`` and joint jerk limits ``jerk`` ``(dof,)`` (rules in the module docstring).
    ``Infeasible`` and ``TimeBudgetExceeded`` as ``time_optimal``."""
    jerk = np.asarray(jerk, dtype=float)
    optimal = time_optimal(path, limits, joint_names=joint_names, deadline=deadline)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.asarray(limits.acceleration, dtype=float) / jerk
    ratio = ratio[np.isfinite(ratio) & (ratio > 0.0)]
    width = FILTER * float(ratio.max()) if ratio.size else SHORTEST * optimal.duration
    knots = optimal.profile.s.copy()
    cap = np.full(len(knots), OPEN * float(optimal.profile.sdot.max()))
    timing = optimal
    for _ in range(ROUNDS):
        law = BoxFiltered(timing.profile, width)
        need, reach = _needs(path, limits, jerk, law)
        if need.max(initial=0.0) <= 1.0 + SETTLED:
            break
        cap = _lower(cap, knots, need, reach)
        capped = CappedPath(path, knots, cap)
        timing = time_optimal(capped, capped_limits(limits), joint_names=(*joint_names, "cap"),
                              deadline=deadline)  # fmt: skip
        deadline.check("jerk-limited timing")
    stretch, peak_jerk = _final_stretch(path, limits, jerk, law)
    final = Stretched(law, stretch) if stretch > 1.0 else law
    return JerkLimited(path, final, optimal, timing, stretch, peak_jerk / stretch**3)


def _pieces(path: JointPath, law: BoxFiltered) -> tuple[np.ndarray, np.ndarray]:
    """Start times and widths of the smooth pieces of q(s(t)): between the filter's breaks and
    the times the path's joins (d3q/ds3 steps) are crossed."""
    cuts = law.breaks()
    if isinstance(path, JoinedPath):
        joins = np.asarray(path.joins(), dtype=float)
        joins = joins[(joins > 0.0) & (joins < law.length)]
        cuts = np.union1d(cuts, law.time_at(joins))
    cuts = cuts[(cuts >= 0.0) & (cuts <= law.duration)]
    t0, width = cuts[:-1], np.diff(cuts)
    keep = width > 1e-12 * law.duration
    return t0[keep], width[keep]


def _sample_times(t0: np.ndarray, width: np.ndarray, intervals: int) -> np.ndarray:
    """``intervals + 1`` times across every piece ``(P, intervals + 1)``, the ends a hair
    inside (the jerk steps there)."""
    f = np.linspace(0.0, 1.0, intervals + 1)
    f[0], f[-1] = NUDGE, 1.0 - NUDGE
    return t0[:, None] + width[:, None] * f


def _needs(
    path: JointPath, limits: PathLimits, jerk: np.ndarray, law: BoxFiltered
) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """The speed factor every checked instant of ``law`` needs (``CHECKS`` intervals of samples
    per smooth piece), and the stretch of path its filter window covered: s and s' of the
    unfiltered law at t - width and at t."""
    raw = law.profile
    t = _sample_times(*_pieces(path, law), CHECKS).ravel()
    factor = _factor(path, limits, jerk, law, t).max(axis=1)
    before, now = np.clip(t - law.width, 0.0, raw.duration), np.clip(t, 0.0, raw.duration)
    return factor, (raw(before), raw(now), raw(before, 1), raw(now, 1))


def _factor(
    path: JointPath, limits: PathLimits, jerk: np.ndarray, law: PathLaw, t: np.ndarray
) -> np.ndarray:
    """Per time ``t`` ``(K,)`` and limit (the rows of ``limits``, then the joint jerks) the
    uniform slow-down factor k >= 0 that brings it within its limit ``(K, m + dof)``: a row
    |A s''/k^2 + B s'^2/k^2 + C| <= h needs k^2 >= moving / (+-h - C), a jerk k^3 >= |q'''| / J."""
    s = law(t)
    sd, sdd = law(t, 1), law(t, 2)
    rows = limits.rows(path(s), path(s, 1), path(s, 2), s)
    h = limits.bounds
    moving = rows.A * sdd[:, None] + rows.B * (sd * sd)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        need2 = np.where(moving > 0, moving / (h - rows.C), moving / (-h - rows.C))
    need2 = np.where(np.isfinite(need2), np.maximum(need2, 0.0), 0.0)
    qddd = joint_motion(path, law, t, jerk=True)[3]
    return np.column_stack([np.sqrt(need2), np.cbrt(np.abs(qddd) / jerk)])


def _lower(
    cap: np.ndarray, knots: np.ndarray, need: np.ndarray, reach: tuple[np.ndarray, ...]
) -> np.ndarray:  # fmt: skip
    """``cap`` at ``knots`` lowered, over the stretch of path ``reach[0:2]`` of every checked
    instant that needs more than 1, to the larger unfiltered speed at its ends ``reach[2:4]``
    over its need (times ``MARGIN``)."""
    bad = np.flatnonzero(need > 1.0 + SETTLED)
    lo = np.clip(np.searchsorted(knots, reach[0][bad], side="right") - 1, 0, len(knots) - 1)
    hi = np.clip(np.searchsorted(knots, reach[1][bad], side="left"), 0, len(knots) - 1)
    value = np.maximum(reach[2][bad], reach[3][bad]) / need[bad] * MARGIN
    span = hi - lo + 1
    first = np.repeat(np.cumsum(span) - span, span)
    at = np.repeat(lo, span) + (np.arange(int(span.sum())) - first)
    lowered = cap.copy()
    np.minimum.at(lowered, at, np.repeat(value, span))
    return lowered


def _final_stretch(
    path: JointPath, limits: PathLimits, jerk: np.ndarray, law: BoxFiltered
) -> tuple[float, np.ndarray]:
    """The uniform slow-down k >= 1 that brings every limit of ``law`` within it, and the
    largest |q_ttt| per joint before it: samples on every smooth piece (between the filter's
    breaks and the times the path's joins are crossed, their ends a hair inside), the peaks
    between them estimated and, near the largest, found exactly."""
    t0, width = _pieces(path, law)
    t = _sample_times(t0, width, PIECE_SAMPLES)
    values = _factor(path, limits, jerk, law, t.ravel()).reshape(*t.shape, -1)
    peak, where = sampled_peaks(values)
    top = float(peak.max(initial=0.0))
    i, r = np.nonzero((peak >= top * (1.0 - NEAR)) & (where > 0.0) & (where < 1.0))
    if i.size:

        def evaluate(c: np.ndarray, frac: np.ndarray, row: np.ndarray) -> np.ndarray:
            at = t0[c] + width[c] * np.clip(frac, NUDGE, 1.0 - NUDGE)
            return _factor(path, limits, jerk, law, at)[np.arange(len(c)), row]

        refined = refine_peaks(evaluate, i, r, where[i, r], PIECE_SAMPLES + 1)
        peak[i, r] = np.maximum(peak[i, r], refined)
    peak_jerk = peak[:, -len(jerk) :].max(axis=0) ** 3 * jerk
    stretch = float(peak.max(initial=0.0)) * (1.0 + AIM)
    return (stretch if stretch > 1.0 + AIM else 1.0), peak_jerk


def _named(binding: tuple[Binding, ...], dof: int) -> tuple[Binding, ...]:
    """``binding`` of a capped path with the cap's velocity row named ``"jerk"``."""
    return tuple(
        Binding(b.start, b.end, "jerk", None) if (b.limit, b.joint) == ("velocity", dof) else b
        for b in binding
    )
