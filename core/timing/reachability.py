"""TOPP-RA's reachability analysis on a grid: controllable sets backward, the fastest profile forward.

Pham and Pham, "A new approach to time-optimal path parameterization based on reachability
analysis", IEEE T-RO 34(3), 2018. On a grid s_0 < ... < s_N with x_i = s'^2 at s_i and a constant
u_i = s'' on [s_i, s_i+1] (so x_i+1 = x_i + 2 d_i u_i), interval i's limits are rows

    lower <= alpha u_i + beta x_i <= upper        (``IntervalRows``, shape (N, R) each)

(a limit at any point of the interval, with x there = x_i + 2 delta u_i, is such a row). The
controllable set K_i (the x_i from which rest at s_N can be reached) is an interval, found backward
from K_N = {0}: each step is a two-variable LP, solved in closed form. Every row bounds u by an
affine function of x (``u >= P_lo + Q_lo x``, ``u <= P_up + Q_up x``), so the x for which some u is
feasible form an interval (its ends by Newton's method on the convex piecewise-linear function
max(lower bounds) - min(upper bounds), vectorized over the grid), and adding the row that keeps
x_i+1 in K_i+1 leaves one affine bound on x per row. The forward pass from x_0 = 0 takes the largest
feasible u at each step (greedy), which is time-optimal among profiles on this grid (TOPP-RA's
theorem). Units: x in [1/s^2] times the path unit squared, u in the path unit per [s^2].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import Infeasible

X_CAP = 1e16
"""Largest s'^2 considered: a path with no speed limit at all is capped here."""
NEWTON_STEPS = 200
"""Most Newton steps of the static range (each leaves a piece of a piecewise-linear function)."""
TOLERANCE = 1e-12
"""Relative slack of the feasibility tests (rounding)."""


@dataclass(frozen=True)
class IntervalRows:
    """The limits of every grid interval: ``lower <= alpha u + beta x <= upper``, each ``(N, R)``
    (``lower`` may be -inf, ``upper`` +inf); ``delta`` ``(N,)`` interval lengths; ``stops``
    ``(N + 1,)`` bool: grid points where the motion must be at rest (dq/ds jumps there)."""

    alpha: np.ndarray
    beta: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    delta: np.ndarray
    stops: np.ndarray


@dataclass(frozen=True)
class Bounds:
    """Per interval, u bounds affine in x (``(N, R)`` each) and the x range of the rows alone."""

    p_lo: np.ndarray
    q_lo: np.ndarray
    p_up: np.ndarray
    q_up: np.ndarray
    x_lo: np.ndarray
    x_hi: np.ndarray


def u_bounds(rows: IntervalRows, x_hi: np.ndarray | None = None) -> Bounds:
    """The affine u bounds of every row with a u term, and the x range where some u fits every
    row (rows without a u term bound x directly; ``x_hi``: a known upper end of each range, such
    as the range of fewer rows). Ranges that are empty have ``x_lo > x_hi``."""
    a, b, lo, up = rows.alpha, rows.beta, rows.lower, rows.upper
    has_u = np.abs(a) > 1e-14
    safe = np.where(has_u, a, 1.0)
    pos = a > 0
    with np.errstate(invalid="ignore", over="ignore"):
        top = np.where(pos, up, lo) / safe  # the bound u <= (top - b x) / a ... as P + Q x
        bottom = np.where(pos, lo, up) / safe
        q = -b / safe
        p_up = np.where(has_u, top, np.inf)
        p_lo = np.where(has_u, bottom, -np.inf)
        q_up = np.where(has_u & np.isfinite(top), q, 0.0)
        q_lo = np.where(has_u & np.isfinite(bottom), q, 0.0)
        # rows without u: lo <= b x <= up
        bpos, bneg = ~has_u & (b > 0), ~has_u & (b < 0)
        cap = np.where(
            bpos, up / np.where(bpos, b, 1.0), np.where(bneg, lo / np.where(bneg, b, 1.0), np.inf)
        )
        floor = np.where(
            bpos, lo / np.where(bpos, b, 1.0), np.where(bneg, up / np.where(bneg, b, 1.0), 0.0)
        )
    broken = (~has_u & (b == 0) & ((lo > 0) | (up < 0))).any(axis=1)
    x_top = np.fmin(np.fmin.reduce(cap, axis=1), X_CAP)  # fmin and fmax pass NaN over
    x_lo = np.fmax(np.fmax.reduce(floor, axis=1), 0.0)
    x_top = np.where(rows.stops, np.minimum(x_top, 0.0), x_top)
    x_top = np.where(broken, -1.0, x_top)
    if x_hi is not None:
        x_top = np.minimum(x_top, x_hi)
    bounds = Bounds(p_lo, q_lo, p_up, q_up, x_lo, x_top)
    hi = _edge(bounds, x_top, from_right=True)
    lo = _edge(bounds, np.minimum(x_lo, np.maximum(hi, 0.0)), from_right=False)
    return Bounds(p_lo, q_lo, p_up, q_up, lo, np.where(lo <= hi, hi, -1.0))


def _edge(b: Bounds, x: np.ndarray, from_right: bool) -> np.ndarray:
    """The largest (``from_right``) or smallest x, starting from ``x`` ``(N,)``, where
    F(x) = max(P_lo + Q_lo x) - min(P_up + Q_up x) <= 0 (Newton's method on the convex F: it never
    steps over the edge; only the intervals not yet settled are iterated); -1 where there is none."""
    x = x.copy()
    todo = np.flatnonzero(x >= 0.0)
    for _ in range(NEWTON_STEPS):
        if todo.size == 0:
            break
        xt = x[todo]
        lower = b.p_lo[todo] + b.q_lo[todo] * xt[:, None]
        upper = b.p_up[todo] + b.q_up[todo] * xt[:, None]
        k = np.arange(todo.size)
        i_lo, i_up = lower.argmax(axis=1), upper.argmin(axis=1)
        low, u = lower[k, i_lo], upper[k, i_up]
        excess = low - u
        scale = np.abs(low) + np.abs(u)
        bad = excess > TOLERANCE * np.where(np.isfinite(scale), scale, 0.0)
        slope = b.q_lo[todo, i_lo] - b.q_up[todo, i_up]
        moves = slope > 0 if from_right else slope < 0
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(moves, excess / np.where(moves, slope, 1.0), 0.0)
        settled = ~bad | (moves & (np.abs(step) <= 1e-14 * np.maximum(xt, 1e-300)))
        x[todo[bad & ~moves]] = -1.0
        nxt = xt - step
        keep = bad & moves & ~settled
        x[todo[keep]] = np.maximum(nxt[keep], 0.0)
        x[todo[keep & (nxt < -TOLERANCE)]] = -1.0
        todo = todo[keep & (nxt >= -TOLERANCE)]
    return x


def _keep(
    a: np.ndarray, b: np.ndarray, top: np.ndarray, sign: np.ndarray
) -> list[list[tuple[float, float]]]:
    """Per row of ``(N, R)`` lines ``a X + b`` on X in [0, ``top``] ``(N,)``, the lines that are
    the lowest (``sign`` +1 for the row) or the highest (-1) somewhere there, as Python pairs for
    scalar loops. Exact: a line below the lower envelope somewhere is below it at the envelope's
    one kink between the lowest lines at both ends (the difference is convex)."""
    cols = np.isfinite(b).any(axis=0)
    a, b = a[:, cols], b[:, cols]
    n, r = a.shape
    if r == 0:
        return [[] for _ in range(n)]
    sa, sb = a * sign[:, None], b * sign[:, None]
    rows = np.arange(n)
    with np.errstate(invalid="ignore", over="ignore"):
        end = sa * top[:, None] + sb
        i0, i1 = sb.argmin(axis=1), end.argmin(axis=1)
        a0, b0, a1, b1 = sa[rows, i0], sb[rows, i0], sa[rows, i1], sb[rows, i1]
        cross = np.where(a0 != a1, (b1 - b0) / np.where(a0 != a1, a0 - a1, 1.0), 0.0)
        xc = np.clip(np.where(np.isnan(cross), 0.0, cross), 0.0, top)
        env = np.minimum(a0 * xc + b0, a1 * xc + b1)
        below = sa * xc[:, None] + sb < env[:, None] - 1e-12 * np.abs(env[:, None])
    keep = below
    keep[rows, i0] = True
    keep[rows, i1] = True
    keep &= np.isfinite(b)
    counts = keep.sum(axis=1)
    pairs = list(zip(a[keep].tolist(), b[keep].tolist(), strict=True))
    cuts = np.concatenate([[0], np.cumsum(counts)]).tolist()
    return [pairs[cuts[i] : cuts[i + 1]] for i in range(n)]


_FAMILIES = ("up_h", "lo_h", "up_u", "lo_u")


class Reachability:
    """The two passes on ``IntervalRows``, with each interval's bounds prepared once: ``update``
    prepares again only the intervals whose rows changed (a tightened limit), ``solve`` runs the
    passes. Each interval keeps, as Python pairs for scalar loops, only the lines that can bound
    its step (``_keep``): about one or two of its rows."""

    def __init__(self, rows: IntervalRows) -> None:
        self.delta = rows.delta
        self._two_d = (2.0 * rows.delta).tolist()
        self.bounds = u_bounds(rows)
        n = len(rows.delta)
        self.lines: dict[str, list[list[tuple[float, float]]]] = {f: [[]] * n for f in _FAMILIES}
        self._top0, self._bottom0 = [0.0] * n, [0.0] * n
        r = rows.alpha.shape[1]
        self._up_l, self._up_c = np.zeros((n, r)), np.zeros((n, r))
        self._lo_l, self._lo_c = np.zeros((n, r)), np.zeros((n, r))
        self._prepare(np.arange(n))
        self._x: list[float] | None = None
        self._lo: list[float] = []
        self._hi: list[float] = []
        self._changed = np.zeros(0, dtype=np.int64)

    def update(self, rows: IntervalRows, changed: np.ndarray) -> None:
        """New ``rows`` (the whole grid) that differ from the last ones on intervals ``changed``."""
        if changed.size == 0:
            return
        if rows.alpha.shape[1] > self.bounds.p_lo.shape[1]:
            self._widen(rows.alpha.shape[1] - self.bounds.p_lo.shape[1])
        sub = IntervalRows(
            *(
                getattr(rows, f)[changed]
                for f in ("alpha", "beta", "lower", "upper", "delta", "stops")
            )
        )
        fresh = u_bounds(sub, self.bounds.x_hi[changed])  # rows were only added
        for name in Bounds.__dataclass_fields__:
            getattr(self.bounds, name)[changed] = getattr(fresh, name)
        self._prepare(changed)  # the lines kept before them still hold a superset
        self._changed = np.unique(np.concatenate([self._changed, changed, (changed - 1).clip(0)]))

    def _widen(self, extra: int) -> None:
        """Room for ``extra`` more rows per interval (rows added by a caller), none binding yet."""
        n = len(self.delta)

        def pad(a: np.ndarray, value: float) -> np.ndarray:
            return np.concatenate([a, np.full((n, extra), value)], axis=1)

        b = self.bounds
        inf = np.inf
        self.bounds = Bounds(pad(b.p_lo, -inf), pad(b.q_lo, 0.0), pad(b.p_up, inf),
                             pad(b.q_up, 0.0), b.x_lo, b.x_hi)  # fmt: skip
        self._up_l, self._up_c = pad(self._up_l, 0.0), pad(self._up_c, inf)
        self._lo_l, self._lo_c = pad(self._lo_l, 0.0), pad(self._lo_c, -inf)

    def _prepare(self, idx: np.ndarray) -> None:
        b, n = self.bounds, len(self.delta)
        w = (0.5 / self.delta[idx])[:, None]
        p_lo, q_lo, p_up, q_up = b.p_lo[idx], b.q_lo[idx], b.p_up[idx], b.q_up[idx]
        s1, s2 = q_lo + w, q_up + w
        flat = 1e-9 * w
        nxt = np.where(idx + 1 < n, np.maximum(b.x_hi[np.minimum(idx + 1, n - 1)], 0.0), 0.0)
        here = np.maximum(b.x_hi[idx], 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            up = s1 > flat
            a = np.where(up, w / np.where(up, s1, 1.0), 0.0)
            c = np.where(up, -p_lo / np.where(up, s1, 1.0), np.inf)
            up_h = (a, c)
            down = s1 < -flat  # rare: only where a joint turns around inside the interval
            some = down.any(axis=1)
            self._store("lo_h", idx, [[]] * len(idx))
            if some.any():
                a = np.where(down, w / np.where(down, s1, 1.0), 0.0)[some]
                c = np.where(down, -p_lo / np.where(down, s1, 1.0), -np.inf)[some]
                minus = -np.ones(int(some.sum()))
                self._store("lo_h", idx[some], _keep(a, c, nxt[some], minus))
            # where x_i+1's set does not start at 0 (rare) these rows bound x_i too
            neg, pos = s2 < -flat, s2 > flat
            inv = 1.0 / np.where(neg | pos, s2, 1.0)
            self._up_l[idx] = np.where(neg, w * inv, 0.0)
            self._up_c[idx] = np.where(neg, -p_up * inv, np.inf)
            self._lo_l[idx] = np.where(pos, w * inv, 0.0)
            self._lo_c[idx] = np.where(pos, -p_up * inv, -np.inf)
        # one pass for the three usual families: the lowest up_h and up_u, the highest lo_u
        k = len(idx)
        sign = np.concatenate([np.ones(2 * k), -np.ones(k)])
        lists = _keep(
            np.concatenate([up_h[0], q_up, q_lo]),
            np.concatenate([up_h[1], p_up, p_lo]),
            np.concatenate([nxt, here, here]),
            sign,
        )
        self._store("up_h", idx, lists[:k])
        self._store("up_u", idx, lists[k : 2 * k])
        self._store("lo_u", idx, lists[2 * k :])
        # with x_i+1's set starting at 0 (the usual case) those rows are constants
        top0 = np.minimum(b.x_hi[idx], self._up_c[idx].min(axis=1)).tolist()
        bottom0 = np.maximum(b.x_lo[idx], self._lo_c[idx].max(axis=1)).tolist()
        if len(idx) == n:
            self._top0, self._bottom0 = top0, bottom0
            return
        for i, t, lo_ in zip(idx.tolist(), top0, bottom0, strict=True):
            self._top0[i], self._bottom0[i] = t, lo_

    def _store(self, name: str, idx: np.ndarray, lists: list[list[tuple[float, float]]]) -> None:
        if len(idx) == len(self.delta):  # every interval, in order
            self.lines[name] = lists
            return
        target = self.lines[name]
        for i, item in zip(idx.tolist(), lists, strict=True):
            target[i] = item

    def solve(self) -> np.ndarray:
        """x ``(N + 1,)`` of the fastest profile: the controllable sets backward, then the greedy
        pass forward. After an ``update``, both passes redo only the stretches from each changed
        interval to where their values meet the previous solve's again."""
        n = len(self.delta)
        if self._x is None:
            lo, hi, x = [0.0] * (n + 1), [0.0] * (n + 1), [0.0] * (n + 1)
            self._backward(lo, hi, [n - 1], set())
            self._forward(lo, hi, x, [0], set())
        else:
            lo, hi, x = self._lo, self._hi, self._x
            dirty = set(self._changed.tolist())
            moved = self._backward(lo, hi, sorted(dirty, reverse=True), dirty)
            starts = sorted(dirty | {max(i - 1, 0) for i in moved})
            self._forward(lo, hi, x, starts, dirty | {i - 1 for i in moved})
        x[-1] = 0.0
        self._lo, self._hi, self._x = lo, hi, x
        self._changed = np.zeros(0, dtype=np.int64)
        return np.array(x)

    def _backward(
        self, lo: list[float], hi: list[float], starts: list[int], dirty: set[int]
    ) -> list[int]:
        """K_i backward from each of ``starts`` (descending) until K_i is the same as before below
        the ``dirty`` intervals; returns the indices whose K changed.

        Raises:
            Infeasible: with ``extra["grid_index"]``, the first interval (from the end) whose set
                is empty: no motion along the path keeps the limits there.
        """
        up_h, lo_h = self.lines["up_h"], self.lines["lo_h"]
        top0, bottom0 = self._top0, self._bottom0
        moved: list[int] = []
        queue, qi = list(starts), 1
        i = queue[0] if queue else -1
        while i >= 0:
            h, l_next = hi[i + 1], lo[i + 1]
            top, bottom = top0[i], bottom0[i]
            for a, c in up_h[i]:
                v = a * h + c
                if v < top:
                    top = v
            for a, c in lo_h[i]:
                v = a * h + c
                if v > bottom:
                    bottom = v
            if l_next > 0.0:
                top = min(top, float(np.min(self._up_l[i] * l_next + self._up_c[i])))
                bottom = max(bottom, float(np.max(self._lo_l[i] * l_next + self._lo_c[i])))
            if top < bottom:
                if top < bottom - TOLERANCE * max(abs(top), abs(bottom), 1e-300):
                    raise Infeasible(
                        "no motion along the path keeps every limit here", extra={"grid_index": i}
                    )
                bottom = top
            if top < 0.0:
                raise Infeasible(
                    "no motion along the path keeps every limit here", extra={"grid_index": i}
                )
            if bottom < 0.0:
                bottom = 0.0
            if dirty and top == hi[i] and bottom == lo[i] and i not in dirty:
                while qi < len(queue) and queue[qi] >= i:
                    qi += 1
                i = queue[qi] if qi < len(queue) else -1
                qi += 1
                continue
            if dirty:
                moved.append(i)
            hi[i], lo[i] = top, bottom
            i -= 1
        if lo[0] > 0.0:
            raise Infeasible("the motion cannot start from rest here", extra={"grid_index": 0})
        return moved

    def _forward(
        self, lo: list[float], hi: list[float], x: list[float], starts: list[int], dirty: set[int]
    ) -> None:
        """The greedy steps from each of ``starts`` (ascending): the largest u that keeps the rows
        and the next controllable set, until x is the same as before past the ``dirty`` ones."""
        ups, downs = self.lines["up_u"], self.lines["lo_u"]
        two_d = self._two_d
        n = len(two_d)
        queue, qi = list(starts), 1
        i = queue[0] if queue else n
        while i < n:
            xi, step = x[i], two_d[i]
            u_hi = (hi[i + 1] - xi) / step
            for q, p in ups[i]:
                v = p + q * xi
                if v < u_hi:
                    u_hi = v
            u_lo = (lo[i + 1] - xi) / step
            for q, p in downs[i]:
                v = p + q * xi
                if v > u_lo:
                    u_lo = v
            u = u_hi if u_hi >= u_lo else 0.5 * (u_hi + u_lo)
            nxt = xi + step * u
            if nxt < lo[i + 1]:
                nxt = lo[i + 1]
            if nxt > hi[i + 1]:
                nxt = hi[i + 1]
            if nxt < 0.0:
                nxt = 0.0
            if dirty and nxt == x[i + 1] and i not in dirty:
                while qi < len(queue) and queue[qi] <= i:
                    qi += 1
                i = queue[qi] if qi < len(queue) else n
                qi += 1
                continue
            x[i + 1] = nxt
            i += 1
