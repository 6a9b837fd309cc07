"""Time-optimal path parameterization whose limits hold at every instant, not only at grid points.

``time_optimal(path, limits)`` times a geometric joint path q(s) (``JointPath``) from rest to rest
in the shortest time that keeps every row of ``PathLimits`` (joint velocity and acceleration, tool
speed, effort; ``core.timing.path_constraints``): TOPP-RA's reachability analysis
(``core.timing.reachability``) on a grid that holds every breakpoint of the path
(``core.timing.path_grid``), with s'' constant on each grid interval.

TOPP-RA keeps its limits at the grid points only; between them they can be exceeded (toppra 0.6.10
by 7.5-56 % on joint accelerations, hungpham2511/toppra#150). Here every interval's limits are kept
at both of its ends (x_i and x_i + 2 d_i u_i, TOPP-RA's "interpolation" discretization), then the
answer is checked densely (``core.timing.dense_check``: samples in every interval, and at the path's
joins, the peak between them estimated and, where it comes near the limit, found to ~1e-13). Where a peak
exceeds its limit, that limit is tightened on that interval alone by the excess and the passes run
again, until every peak is within ``TOLERANCE`` (the contract's 1e-9 relative) of its limit; if that
does not converge in ``ROUNDS``, the whole profile is slowed uniformly until it is. The answer
(``TimeOptimal``) is a ``Profile`` s(t) with constant s'' between grid times (``switch_times``), which
samples q, q', q'' exactly (``sample``), reports which limit binds where (``binding``) and the
duration of the untightened grid optimum (``grid_duration``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.budget import NO_DEADLINE, Deadline
from core.errors import Infeasible
from core.timing.dense_check import DENSE, Check, values
from core.timing.joint_path import JointPath
from core.timing.path_constraints import PathLimits, Rows
from core.timing.path_grid import PathSamples, one_sided, path_grid, sample_path, stops
from core.timing.reachability import IntervalRows, Reachability
from core.timing.speed_limited import GridTiming
from core.trajectory import default_joint_names

TOLERANCE = 1e-9
"""Largest relative excess of a limit anywhere (velocity rows: of the squared velocity)."""
AIM = 1e-11
"""Relative margin a tightened limit leaves below the limit."""
ROUNDS = 10
"""Most rounds of tightening before the uniform slow-down."""


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
    inner_s = s[check.parent][:, None] + np.diff(s)[check.parent][:, None] * (
        check.lo[:, None] + (check.hi - check.lo)[:, None] * (np.arange(1, DENSE) / DENSE)
    )
    _gravity_check(limits, path, (start, end, check.inner), (s[:-1], s[1:], inner_s.ravel()), names)
    deadline.check("time-optimal timing")
    stop = stops(path, grid)
    gamma = np.ones((len(d), len(h)))
    grid_duration = 0.0
    worst = np.inf
    last = np.full((2, len(d), len(h)), np.nan)  # ends and peak of the rows cut last round
    passes = Reachability(_rows(start, end, d, h * gamma, stop))
    changed = np.zeros(0, dtype=np.int64)
    before: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(ROUNDS):
        passes.update(_rows(start, end, d, h * gamma, stop), changed)
        x = _solve(passes, path, s)
        if not grid_duration:
            grid_duration = GridTiming.from_speeds(s, np.sqrt(x)).duration
        peak = check.peaks(path, limits, s, x, h, before)
        before = (x, peak)
        deadline.check("time-optimal timing")
        worst = float(peak.max(initial=0.0))
        if worst <= 1.0 + TOLERANCE:
            break
        over = peak > 1.0
        ends = _end_ratios(start, end, x, d, h)
        gamma[over] = _cut(ends[over], peak[over], last[0][over], last[1][over], gamma[over])
        changed = np.flatnonzero(over.any(axis=1))
        last[:] = np.nan
        last[0][over], last[1][over] = ends[over], peak[over]
    else:
        x = _slow_down(x, d, start, h, worst)
        worst = float(check.peaks(path, limits, s, x, h).max(initial=0.0))
    binding = _binding(limits, start, end, x, d, h * gamma, s)
    return TimeOptimal(path, s, x, binding, grid_duration, worst)


def _rows(
    start: Rows, end: Rows, d: np.ndarray, bound: np.ndarray, stop: np.ndarray
) -> IntervalRows:
    """Every interval's rows at both of its ends with bounds ``bound`` ``(N, m)``."""
    w = 2.0 * d[:, None]
    return IntervalRows(
        alpha=np.concatenate([start.A, end.A + w * end.B], axis=1),
        beta=np.concatenate([start.B, end.B], axis=1),
        lower=np.concatenate([-bound - start.C, -bound - end.C], axis=1),
        upper=np.concatenate([bound - start.C, bound - end.C], axis=1),
        delta=d,
        stops=stop[:-1],
    )


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


def _cut(
    ends: np.ndarray, peak: np.ndarray, ends_before: np.ndarray, peak_before: np.ndarray,
    gamma: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """New bounds (as fractions of the limit) for rows whose interior ``peak`` exceeds the limit
    while their ``ends`` keep it: lower the ends by the excess divided by how much the peak follows
    the ends (a secant from the previous round's cut of the same row; 0.5 at first: the peak
    follows by less than 1:1 where the neighbours' limits set the interval's u, measured 0.3-0.7)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (peak_before - peak) / (ends_before - ends)
    slope = np.where(np.isfinite(slope) & (slope > 0.05), np.minimum(slope, 1.5), 0.5)
    target = np.minimum(gamma, ends) - (peak - 1.0 + AIM) / slope
    return np.maximum(target, 0.5 * np.minimum(gamma, ends)) * (1.0 - AIM)


def _end_ratios(start: Rows, end: Rows, x: np.ndarray, d: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Every row's value over ``h`` at the ends of every interval, the larger of the two ``(N, m)``."""
    u = np.diff(x) / (2.0 * d)
    return np.maximum(values(start, u, x[:-1]), values(end, u, x[1:])) / h


def _slow_down(
    x: np.ndarray, d: np.ndarray, start: Rows, h: np.ndarray, worst: float
) -> np.ndarray:
    """x scaled by 1/lambda^2 (the same motion, slower) so that every limit holds: rows without a
    constant term scale with x; effort rows are solved for lambda at every sample."""
    lam2 = max(worst, 1.0) * (1.0 + 4.0 * AIM)
    u = np.diff(x) / (2.0 * d)
    moving = start.A * u[:, None] + start.B * x[:-1, None]
    c = start.C
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(moving > 0, moving / (h - c), moving / (-h - c))
    lam2 = max(lam2, float(np.nan_to_num(need, nan=0.0, posinf=0.0).max()) * (1.0 + 4.0 * AIM))
    return x / lam2


def _gravity_check(
    limits: PathLimits,
    path: JointPath,
    rows: tuple[Rows, ...],
    at: tuple[np.ndarray, ...],
    names: tuple[str, ...],
) -> None:
    """``Infeasible`` naming the joint and ``s`` where gravity alone exceeds an effort limit."""
    if limits.effort is None:
        return
    h = limits.bounds
    effort = np.array([kind == "effort" for kind, _ in limits.labels()])
    labels = limits.labels()
    for r, s in zip(rows, at, strict=True):
        over = (np.abs(r.C) > h) & effort
        if over.any():
            k, j = (int(v) for v in np.argwhere(over)[0])
            joint = labels[j][1]
            frac = float(s[k] / path.length)
            raise Infeasible(
                f"gravity alone exceeds the effort limit of joint {names[joint or 0]} at "
                f"s={frac:.6g}",
                s=frac,
                joint=joint,
                extra={"limit": "effort"},
            )


def _binding(
    limits: PathLimits, start: Rows, end: Rows, x: np.ndarray, d: np.ndarray,
    bound: np.ndarray, s: np.ndarray,
) -> tuple[Binding, ...]:  # fmt: skip
    """Per interval the row nearest its (tightened) bound at the interval's ends (an interval
    where none binds takes the next interval's), as stretches; stretches shorter than 1/200 of
    the path join the one before."""
    ratio = _end_ratios(start, end, x, d, bound)
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
