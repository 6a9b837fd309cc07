"""Time-optimal path parameterization whose limits hold at every instant, not only at grid points.

``time_optimal(path, limits)`` times a geometric joint path q(s) (``JointPath``) from rest to rest
in the shortest time that keeps every row of ``PathLimits`` (joint velocity and acceleration, tool
speed, effort; ``core.timing.path_constraints``): TOPP-RA's reachability analysis
(``core.timing.reachability``) on a grid that holds every breakpoint of the path
(``core.timing.path_grid``), with s'' constant on each grid interval.

TOPP-RA keeps its limits at the grid points only; between them they can be exceeded (toppra 0.6.10
by 7.5-56 % on joint accelerations, hungpham2511/toppra#150). Here every interval's limits are kept
at both of its ends and at its midpoint (with x = x_i + 2 f d_i u_i at fraction f, a limit there is
a row in (u_i, x_i)), then the answer is checked densely (``core.timing.dense_check``: samples in
every interval and at the path's joins, the peak between them estimated and, where it comes near
the limit, found to ~1e-13). Where a peak exceeds its limit, the limit at that very point is added
to the interval's rows (a cut: exact, so nothing is given away) and the passes run again; once the
largest excess is below ``FINISH``, the motion is slowed uniformly by it instead (s'^2 / lambda^2:
rows without a constant term scale exactly, so no re-check is needed; with gravity in the effort
rows the check runs again). Every peak ends within ``TOLERANCE`` (the contract's 1e-9 relative) of
its limit. The answer (``TimeOptimal``) is a ``Profile`` s(t) with constant s'' between grid times
(``switch_times``), which samples q, q', q'' exactly (``sample``), reports which limit binds where
(``binding``) and the duration of the first grid optimum (``grid_duration``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.errors import Infeasible
from core.timing.dense_check import DENSE, Check, Peaks
from core.timing.joint_path import JointPath
from core.timing.path_constraints import PathLimits, Rows
from core.timing.path_grid import NUDGE, PathSamples, one_sided, path_grid, sample_path, stops
from core.timing.reachability import IntervalRows, Reachability
from core.timing.speed_limited import GridTiming
from core.trajectory import default_joint_names

TOLERANCE = 1e-9
"""Largest relative excess of a limit anywhere (velocity rows: of the squared velocity)."""
AIM = 1e-11
"""Relative margin the finishing slow-down leaves below the limit."""
FINISH = 3e-3
"""Largest excess (relative) left to the finishing slow-down rather than to another round of
cuts: it lengthens the motion by at most half of it (0.15 %)."""
ROUNDS = 12
"""Most rounds."""
SETTLE = 4
"""Rounds kept for the slow-down: from round ``ROUNDS - SETTLE`` on it finishes whatever the
excess (slow-downs under effort limits, whose gravity part does not scale, may take two)."""


@dataclass(frozen=True)
class Binding:
    """One stretch of the path where one limit binds: ``start`` and ``end`` as fractions of the
    path length, ``limit`` a kind of ``path_constraints.KINDS`` (or ``"none"``), ``joint`` the
    joint index (None for tool speeds)."""

    start: float
    end: float
    limit: str
    joint: int | None


class TimeOptimal:
    """The time-optimal s(t) along ``path``: a ``core.timing.Profile`` (s in the path's units).

    Attributes:
        duration: [s].
        switch_times: Grid times ``(N + 1,)`` [s]: s'' is constant between them.
        binding: Which limit binds where (``Binding`` stretches, in path order).
        grid_duration: Duration [s] of the first, untightened grid optimum.
        peak_ratio: Largest value of any limit over its bound found by the dense check.
    """

    def __init__(
        self,
        path: JointPath,
        s: np.ndarray,
        x: np.ndarray,
        binding: tuple[Binding, ...],
        grid_duration: float,
        peak_ratio: float,
    ) -> None:
        self.path = path
        self.profile = GridTiming.from_speeds(s, np.sqrt(np.maximum(x, 0.0)))
        self.duration = self.profile.duration
        self.switch_times = self.profile.t
        self.binding = binding
        self.grid_duration = grid_duration
        self.peak_ratio = peak_ratio

    def __call__(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """s, s', s'' at times ``t`` [s] ``(K,)``."""
        return self.profile(t, order)

    def time_at(self, s: np.ndarray) -> np.ndarray:
        """Times [s] at which the motion reaches path parameters ``s``."""
        return self.profile.time_at(s)

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q' = q_s s', q'' = q_s s'' + q_ss s'^2 at times ``t`` ``(K,)``, each ``(K, dof)``:
        exact derivatives of q(s(t)) (at a switch time, s'' of the interval that starts there)."""
        s, sd, sdd = (self.profile(t, k) for k in (0, 1, 2))
        p = sample_path(self.path, s)
        return p.q, p.dq * sd[:, None], p.dq * sdd[:, None] + p.ddq * (sd * sd)[:, None]


def time_optimal(
    path: JointPath,
    limits: PathLimits,
    *,
    joint_names: tuple[str, ...] = (),
    deadline: Deadline = NO_DEADLINE,
) -> TimeOptimal:
    """The shortest rest-to-rest timing of ``path`` that keeps ``limits`` everywhere (within
    ``TOLERANCE``). ``Infeasible`` names the joint (``joint_names``, default j1..jn) and the path
    fraction ``s`` where gravity alone exceeds an effort limit, or where no motion keeps the
    limits; ``deadline`` is checked between rounds (``TimeBudgetExceeded``)."""
    names = tuple(joint_names) or default_joint_names(path.dof)
    grid = path_grid(path)
    s, d = grid.s, np.diff(grid.s)
    h = limits.bounds
    start = limits.rows(*one_sided(path, s[:-1], grid.breaks[:-1], d, +1.0))
    end = limits.rows(*one_sided(path, s[1:], grid.breaks[1:], d, -1.0))
    check = Check.build(path, limits, s, start, end)
    _gravity_check(limits, path, check, s, names)
    deadline.check("time-optimal timing")
    middle = limits.rows(*sample_path(path, s[:-1] + 0.5 * d))
    rows = _rows(((0.0, start), (0.5, middle), (1.0, end)), d, h, stops(path, grid))
    passes = Reachability(rows)
    grid_duration = 0.0
    before: tuple[np.ndarray, Peaks] | None = None
    scale = 1.0  # lambda^2 of the slow-down that finishes
    ranked = np.zeros((len(d), len(h)))  # the peaks of the last round without a slow-down
    for round_ in range(ROUNDS):
        x = _solve(passes, path, s) / scale
        if not grid_duration:
            grid_duration = GridTiming.from_speeds(s, np.sqrt(x)).duration
        peaks = check.peaks(path, limits, s, x, h, before)
        before = (x, peaks)
        if scale == 1.0:
            ranked = peaks.value
        deadline.check("time-optimal timing")
        worst = float(peaks.value.max(initial=0.0))
        if worst <= 1.0 + TOLERANCE:
            break
        i, r = np.nonzero(peaks.value > 1.0 + AIM)
        over = (i, r)
        cut = _at_peaks(path, limits, s, over, peaks.at[over])
        if worst <= 1.0 + FINISH or scale > 1.0 or round_ >= ROUNDS - SETTLE:
            # close enough: the same motion, slower
            lam2 = _slowdown(cut, x, d, h, over)
            scale *= lam2
            if check.C is None:  # every row scales with 1 / lam2: nothing left to check
                x, worst = x / lam2, worst / lam2
                break
            continue
        rows = _with_cuts(rows, cut, d, h, over)
        passes.update(rows, np.unique(i))
    else:  # pragma: no cover - the slow-downs settle within SETTLE rounds
        raise Infeasible(f"the timing did not settle within its limits in {ROUNDS} rounds")
    binding = _binding(limits, ranked, s)
    return TimeOptimal(path, s, x, binding, grid_duration, worst)


def _rows(
    samples: tuple[tuple[float, Rows], ...], d: np.ndarray, bound: np.ndarray, stop: np.ndarray
) -> IntervalRows:
    """Every interval's rows at the fractions of ``samples`` ((fraction, rows there) pairs: with
    x = x_i + 2 f d_i u_i there, a limit there is a row in (u_i, x_i)), bounds ``bound``."""
    return IntervalRows(
        alpha=np.concatenate([r.A + (2.0 * f * d)[:, None] * r.B for f, r in samples], axis=1),
        beta=np.concatenate([r.B for _, r in samples], axis=1),
        lower=np.concatenate([_lower(r.A, r.B, r.C, bound) for _, r in samples], axis=1),
        upper=np.concatenate([bound - r.C for _, r in samples], axis=1),
        delta=d,
        stops=stop[:-1],
    )


def _lower(A: np.ndarray, B: np.ndarray, C: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """The lower bounds of rows ``-bound - C``, or -inf for rows that cannot go below 0 (B x,
    B >= 0: a squared speed, since x >= 0 everywhere): bounds that never bind cost the passes
    a line each."""
    return np.where((A == 0.0) & (C == 0.0) & (B >= 0.0), -np.inf, -bound - C)


def _solve(passes: Reachability, path: JointPath, s: np.ndarray) -> np.ndarray:
    """x on the grid; ``Infeasible`` names the path fraction where no motion keeps the limits."""
    try:
        return passes.solve()
    except Infeasible as e:
        i = int(e.extra.get("grid_index", 0))
        raise Infeasible(
            f"no motion along the path keeps every limit at s={s[i] / path.length:.6g}",
            s=float(s[i] / path.length),
        ) from e


def _at_peaks(
    path: JointPath, limits: PathLimits, s: np.ndarray, over: tuple[np.ndarray, np.ndarray],
    at: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The interval fractions (a hair inside the interval) and A, B, C of the rows ``over`` =
    (interval, row) at their peaks ``at``, each ``(C,)``."""
    i, r = over
    g = np.clip(at, NUDGE, 1.0 - NUDGE)
    rows = limits.rows(*sample_path(path, s[i] + g * (s[i + 1] - s[i])))
    pick = np.arange(len(i))
    return g, rows.A[pick, r], rows.B[pick, r], rows.C[pick, r]


def _with_cuts(
    rows: IntervalRows, cut: tuple[np.ndarray, ...], d: np.ndarray, h: np.ndarray,
    over: tuple[np.ndarray, np.ndarray],
) -> IntervalRows:  # fmt: skip
    """``rows`` with one more row per (interval, row) ``over``: the limit at its peak ``cut``
    (columns added as needed; intervals without a new row get rows that bind nothing)."""
    i, r = over
    g, A, B, C = cut
    first = np.concatenate([[True], i[1:] != i[:-1]])  # ``over`` is sorted by interval
    rank = np.arange(len(i)) - np.flatnonzero(first)[np.cumsum(first) - 1]
    n, wide = len(d), int(rank.max()) + 1
    alpha, beta = np.zeros((n, wide)), np.zeros((n, wide))
    lower, upper = np.full((n, wide), -np.inf), np.full((n, wide), np.inf)
    alpha[i, rank] = A + 2.0 * g * d[i] * B
    beta[i, rank] = B
    lower[i, rank], upper[i, rank] = _lower(A, B, C, h[r]), h[r] - C
    return IntervalRows(
        alpha=np.concatenate([rows.alpha, alpha], axis=1),
        beta=np.concatenate([rows.beta, beta], axis=1),
        lower=np.concatenate([rows.lower, lower], axis=1),
        upper=np.concatenate([rows.upper, upper], axis=1),
        delta=rows.delta,
        stops=rows.stops,
    )


def _slowdown(
    cut: tuple[np.ndarray, ...], x: np.ndarray, d: np.ndarray, h: np.ndarray,
    over: tuple[np.ndarray, np.ndarray],
) -> float:  # fmt: skip
    """The factor lambda^2 >= 1 by which x must shrink (the motion slowed by lambda) so that
    every row ``over`` keeps its limit at its peak ``cut``: the moving part A u + B x of a row
    scales by 1/lambda^2, its constant part (gravity) not."""
    i, r = over
    g, A, B, C = cut
    u = (x[i + 1] - x[i]) / (2.0 * d[i])
    moving = A * u + B * (x[i] + 2.0 * g * d[i] * u)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(moving > 0, moving / (h[r] - C), moving / (-h[r] - C))
    need = np.nan_to_num(need, nan=1.0, posinf=1.0, neginf=1.0)
    return max(1.0, float(need.max(initial=1.0))) * (1.0 + AIM)


def _gravity_check(
    limits: PathLimits, path: JointPath, check: Check, s: np.ndarray, names: tuple[str, ...]
) -> None:
    """``Infeasible`` naming the joint and ``s`` where gravity alone exceeds an effort limit (at
    the first dense-check sample where it does)."""
    if limits.effort is None or check.C is None:
        return
    h = limits.bounds
    labels = limits.labels()
    effort = np.array([kind == "effort" for kind, _ in labels])
    over = (np.abs(check.C) > h) & effort
    if not over.any():
        return
    piece, k, j = (int(v) for v in np.argwhere(over)[0])
    i = int(check.parent[piece])
    f = check.lo[piece] + (check.hi[piece] - check.lo[piece]) * k / DENSE
    frac = float((s[i] + f * (s[i + 1] - s[i])) / path.length)
    joint = labels[j][1]
    raise Infeasible(
        f"gravity alone exceeds the effort limit of joint {names[joint or 0]} at s={frac:.6g}",
        s=frac,
        joint=joint,
        extra={"limit": "effort"},
    )


def _binding(limits: PathLimits, ratio: np.ndarray, s: np.ndarray) -> tuple[Binding, ...]:
    """Per interval the row with the largest peak over its bound ``ratio`` ``(N, m)`` if it is
    at the limit (an interval where none is takes the next interval's), as stretches;
    stretches shorter than 1/200 of the path join the one before."""
    row = np.where(ratio.max(axis=1) >= 1.0 - 1e-6, ratio.argmax(axis=1), -1)
    # an interval bound by none of its own rows is on its way to the next one's limit
    known = np.flatnonzero(row >= 0)
    if known.size:
        row = row[known[np.minimum(np.searchsorted(known, np.arange(len(row))), known.size - 1)]]
    labels = limits.labels()
    length = s[-1]
    out: list[Binding] = []
    cut = np.flatnonzero(np.diff(row)) + 1
    for a, b in zip(np.concatenate([[0], cut]), np.concatenate([cut, [len(row)]]), strict=True):
        kind, joint = ("none", None) if row[a] < 0 else labels[row[a]]
        lo, hi = float(s[a] / length), float(s[b] / length)
        if out and (hi - lo < 0.005 or (out[-1].limit, out[-1].joint) == (kind, joint)):
            out[-1] = Binding(out[-1].start, hi, out[-1].limit, out[-1].joint)
        else:
            out.append(Binding(lo, hi, kind, joint))
    return tuple(out)


__all__ = ["Binding", "PathSamples", "TimeOptimal", "time_optimal"]
