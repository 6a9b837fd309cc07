"""The continuous check of a joint motion: first contact and a certified minimum clearance.

Joints move linearly between consecutive returned points. Over any interval of that motion a pair's
distance cannot fall below ``(d_a + d_b - B) / 2``, with ``d_a``, ``d_b`` its distances at the ends and
``B`` its motion bound (``motion_weights`` applied to the joint travel over the interval;
``robots.collision.motion_bound``). Branch and bound on (interval, pair) items, from every
``KEY_STEP``-th returned point: an item is split (at its middle returned point, or a single segment
at its joint midpoint) while its bound

* is below the pair's threshold (a possible contact not located yet: its start is clear and earlier
  than the first contact found), or
* is more than ``CLEARANCE_TOLERANCE`` below the smallest distance found so far (no contact found).

So every settled item's bound is at least the smallest distance found minus that tolerance, and
``min_clearance``, the smallest settled bound, is a certified lower bound of the true minimum over
the whole motion (between the returned points too), within ``CLEARANCE_TOLERANCE`` of it. A contact
is an evaluated configuration below the threshold (the earliest found); a segment whose motion bound
falls below ``MOTION_TOLERANCE`` while its bound is still below the threshold is a contact too (its
distance there cannot be proven clear), so a clear answer always means every pair stayed at or above
its threshold at every instant.

Memory is bounded by construction (``CHECK_WORKING_BYTES`` beyond the caller's arrays, whatever the
points x pairs): the motion is checked in windows of at most ``WINDOW_ITEMS`` starting items; items
are processed depth-first in batches of ``BATCH`` making at most ``STEP_CHILDREN`` pieces (so a
bounded number of items waits per depth); distances are computed ``ENTRY_CHUNK`` entries at a time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from core.errors import TooLarge

CLEARANCE_TOLERANCE = 9e-5
"""[m] ``min_clearance`` is certified within this of the true minimum (the contract: 1e-4)."""
MOTION_TOLERANCE = 1e-7
"""[m] A segment piece whose motion bound is below this is not split further: a contact when its
bound is still below the threshold, else settled."""
MIN_PIECE = 2.0**-40
"""Smallest share of one returned segment an item may cover (ends the halving in any case)."""
KEY_STEP = 32
"""The check first evaluates every KEY_STEP-th returned point, then refines."""
MAX_KEY_ENTRIES = 5_000_000
"""Most (key point, pair) entries of one continuous check: points x pairs / KEY_STEP (TooLarge: a
bound on the time of a check, its memory being bounded by construction)."""
WINDOW_ITEMS = 1 << 16
"""Most (interval, pair) items a window of the motion starts with."""
BATCH = 4096
"""Items examined per step (depth-first)."""
MAX_SPLIT = 16
"""Most pieces one item is cut into in one step: as many as a flat distance would need to settle,
rounded up to a power of 2 (so items of different pairs over one segment share their cut points)."""
STEP_CHILDREN = 8192
"""Most pieces made in one step (the rest of its items wait for a later step)."""
ENTRY_CHUNK = 16_384
"""Most pair distances computed in one vectorized call."""
ITEM_BYTES = 56
"""Bytes of one item (start and end point, start and end fraction, pair, two distances)."""
ENTRY_BYTES = 2048
"""Bytes of working memory per entry of a distance call, at most (measured peak: 1.4 KiB for box and
cylinder entries, the golden-section search's arrays and one configuration's joint placements)."""
MAX_DEPTH = int(math.log2(KEY_STEP)) + 41
"""Deepest split of a starting item: log2(KEY_STEP) returned points, then ``MIN_PIECE`` halvings."""
CHECK_WORKING_BYTES = (
    (WINDOW_ITEMS + (MAX_DEPTH + 2) * STEP_CHILDREN) * ITEM_BYTES
    + ENTRY_CHUNK * ENTRY_BYTES
    + (8 << 20)
)
"""Most bytes one ``check_path`` call allocates beyond its inputs (its result included): the items of
one window, the items waiting at each depth (the rest of a step's pieces and the items left for a
later step: at most ``STEP_CHILDREN``), one distance call, and 8 MiB for the window's joint travel
(at most ``MAX_WINDOW_ROWS`` rows) and small arrays. About 64 MiB."""
MAX_WINDOW_ROWS = 65_536
"""Most returned points in one window (bounds its joint travel array: 65,536 x dof x 8 bytes)."""


@dataclass(frozen=True)
class Contact:
    """The first configuration found closer than the threshold.

    Attributes:
        time: [s] from the start of the motion.
        links: ``(robot_link, obstacle_name_or_link)``.
        distance: [m] signed (negative: penetration).
        index: Index of the returned segment (0-based) that holds the contact.
    """

    time: float
    links: tuple[str, str]
    distance: float
    index: int


@dataclass(frozen=True)
class PathCheck:
    """Result of a continuous check.

    Attributes:
        contact: First contact, or None when the motion is clear.
        min_clearance: [m] a certified lower bound of the smallest distance over every checked pair
            and the whole motion, within ``CLEARANCE_TOLERANCE`` of it when there is no contact
            (with one, the smallest found up to it); inf when no pair is checked.
        closest: ``(links, time)`` of the smallest distance evaluated.
        evaluations: Pair distances computed.
    """

    contact: Contact | None
    min_clearance: float
    closest: tuple[tuple[str, str], float] | None
    evaluations: int


class Items(NamedTuple):
    """(interval, pair) items: ``i``-``j`` returned points (``j - i >= 2``), or within segment ``i``
    (``j == i + 1``) from fraction ``fa`` to ``fb``; ``p`` the pair; ``da``, ``db`` its distances
    (or lower bounds) at the ends."""

    i: np.ndarray
    j: np.ndarray
    fa: np.ndarray
    fb: np.ndarray
    p: np.ndarray
    da: np.ndarray
    db: np.ndarray

    def take(self, k: np.ndarray | slice) -> Items:
        return Items(*(x[k] for x in self))


Evaluate = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]
"""``(configurations (U, dof), config index (E,), pair (E,), floor [m]) -> distances (E,)``."""


@dataclass
class _State:
    """What the search knows so far (module docstring)."""

    t: float = math.inf  # first contact: time, pair, distance, segment
    p: int = -1
    d: float = 0.0
    seg: int = -1
    upper: float = math.inf  # the smallest distance evaluated, its time and pair
    upper_t: float = 0.0
    upper_p: int = -1
    lower: float = math.inf  # the smallest bound of a settled item
    count: int = 0


class ContinuousCheck:
    """One run of the check over ``times`` ``(N,)`` [s] and ``qs`` ``(N, dof)``.

    Args:
        evaluate: Distances of (configuration, pair) entries.
        threshold: ``(P,)`` [m] contact threshold of each pair.
        weights: ``(P, dof)`` motion bound (``motion_weights``).
    """

    def __init__(
        self,
        times: np.ndarray,
        qs: np.ndarray,
        evaluate: Evaluate,
        threshold: np.ndarray,
        weights: np.ndarray,
    ) -> None:
        self.times, self.qs = times, qs
        self.evaluate, self.thr, self.W = evaluate, threshold, weights
        self.state = _State()
        self.n, self.P = len(qs), len(threshold)
        self._travel0 = 0  # first row of the window's cumulative travel
        self._travel = np.zeros((1, qs.shape[1]))

    # --- points of the motion -----------------------------------------------------------------
    def _at(self, i: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions ``(E, dof)`` and times ``(E,)`` at fraction ``f`` of segment ``i``."""
        nxt = np.minimum(i + 1, self.n - 1)
        q = self.qs[i] + f[:, None] * (self.qs[nxt] - self.qs[i])
        return q, self._time(i, f)

    def _time(self, i: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Times [s] ``(E,)`` at fraction ``f`` of segment ``i``."""
        nxt = np.minimum(i + 1, self.n - 1)
        return self.times[i] + f * (self.times[nxt] - self.times[i])

    def _distances(self, i: np.ndarray, f: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Distances of pairs ``p`` at points ``(i, f)``, chunked; noted (contact, smallest)."""
        out = np.empty(len(p))
        for s in range(0, len(p), ENTRY_CHUNK):
            ii, ff, pp = i[s : s + ENTRY_CHUNK], f[s : s + ENTRY_CHUNK], p[s : s + ENTRY_CHUNK]
            ui, uf, c = _unique_points(ii, ff)
            q, t = self._at(ui, uf)
            d = self.evaluate(q, c, pp, self.state.upper)
            self._note(t[c], ii, ff, pp, d)
            out[s : s + len(d)] = d
        return out

    def _note(
        self, t: np.ndarray, i: np.ndarray, f: np.ndarray, p: np.ndarray, d: np.ndarray
    ) -> None:
        st = self.state
        st.count += len(d)
        if len(d) == 0:
            return
        k = int(np.argmin(d))
        if d[k] < st.upper:
            st.upper, st.upper_t, st.upper_p = float(d[k]), float(t[k]), int(p[k])
        bad = np.flatnonzero((d < self.thr[p]) & (t < st.t))
        if len(bad):
            b = bad[np.lexsort((d[bad] - self.thr[p[bad]], t[bad]))[0]]
            seg = int(i[b]) if f[b] > 0 else max(int(i[b]) - 1, 0)
            st.t, st.p, st.d, st.seg = float(t[b]), int(p[b]), float(d[b]), seg

    # --- the search ---------------------------------------------------------------------------
    def run(self) -> None:
        """Check the motion window by window (stops after the window holding a contact)."""
        n, P = self.n, self.P
        if n == 1:
            self._distances(np.zeros(P, dtype=int), np.zeros(P), np.arange(P))
            self.state.lower = self.state.upper
            return
        keys_per_window = max(2, WINDOW_ITEMS // P)
        rows = min((keys_per_window - 1) * KEY_STEP, MAX_WINDOW_ROWS)
        for a in range(0, n - 1, rows):
            if self.state.t <= self.times[a]:
                break
            self._window(a, min(a + rows, n - 1))

    def _window(self, a: int, b: int) -> None:
        """Every item of rows ``a`` .. ``b`` (inclusive), depth first."""
        steps = np.abs(np.diff(self.qs[a : b + 1], axis=0))
        self._travel0 = a
        self._travel = np.vstack([np.zeros(self.qs.shape[1]), np.cumsum(steps, axis=0)])
        del steps
        keys = np.unique(np.r_[np.arange(a, b + 1, KEY_STEP), b])
        P, m = self.P, len(keys) - 1
        D = self._distances(
            np.repeat(keys, P), np.zeros(len(keys) * P), np.tile(np.arange(P), len(keys))
        ).reshape(len(keys), P)
        stack = [
            Items(
                np.repeat(keys[:-1], P),
                np.repeat(keys[1:], P),
                np.zeros(m * P),
                np.ones(m * P),
                np.tile(np.arange(P), m),
                D[:-1].reshape(-1),
                D[1:].reshape(-1),
            )
        ]
        del D
        while stack:
            items = stack.pop()
            if len(items.p) > BATCH:
                stack.append(items.take(slice(BATCH, None)))
                items = items.take(slice(0, BATCH))
            later, children = self._step(items)
            if later is not None:
                stack.append(later)
            if children is not None:
                stack.append(children)

    def _bound(self, it: Items) -> np.ndarray:
        """Motion bound [m] of each item: ``W[p] @`` the joint travel over it."""
        multi = it.j - it.i >= 2
        travel = np.empty((len(it.p), self.qs.shape[1]))
        if multi.any():
            C, a = self._travel, self._travel0
            travel[multi] = C[it.j[multi] - a] - C[it.i[multi] - a]
        s = ~multi
        if s.any():
            i = it.i[s]
            step = np.abs(self.qs[i + 1] - self.qs[i])
            travel[s] = (it.fb[s] - it.fa[s])[:, None] * step
        return np.einsum("kd,kd->k", travel, self.W[it.p])

    def _step(self, it: Items) -> tuple[Items | None, Items | None]:
        """Settle or split each item: ``(items left for a later step, children)`` (the children's
        distances at the new split points evaluated)."""
        st, thr = self.state, self.thr[it.p]
        B = self._bound(it)
        low = (it.da + it.db - B) / 2
        single = it.j - it.i == 1
        t_a = self._time(it.i, np.where(single, it.fa, 0.0))
        need_contact = (low < thr) & (it.da >= thr) & (t_a < st.t)
        target = st.upper - CLEARANCE_TOLERANCE
        need_min = low < target if st.t == math.inf else np.zeros(len(low), dtype=bool)
        keep = need_contact | need_min
        tiny = single & ((B < MOTION_TOLERANCE) | (it.fb - it.fa < MIN_PIECE))
        settled = ~keep | tiny
        if settled.any():
            st.lower = min(st.lower, float(low[settled].min()))
        stuck = np.flatnonzero(tiny & need_contact & (it.db >= thr))
        if len(stuck):  # a piece too small to split whose distance cannot be proven clear
            k = stuck[np.argmin(t_a[stuck])]
            if t_a[k] < st.t:
                st.t, st.p, st.d, st.seg = float(t_a[k]), int(it.p[k]), float(low[k]), int(it.i[k])
        split = np.flatnonzero(keep & ~tiny)
        if len(split) == 0:
            return None, None
        # pieces: as many as a flat distance would need to settle (at least 2, at most MAX_SPLIT)
        near = np.minimum(it.da, it.db)[split]
        goal = np.where(need_min[split], target, -math.inf)
        goal = np.where(need_contact[split], np.maximum(goal, thr[split]), goal)
        gap = near - goal
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(gap > 0, np.ceil(B[split] / (2 * gap)), 2.0)
        k = np.clip(np.nan_to_num(k, nan=2.0), 2, MAX_SPLIT)
        k = (2 ** np.ceil(np.log2(k))).astype(int)  # dyadic cuts: pairs on one segment share them
        span = (it.j - it.i)[split]
        k = np.where(span >= 2, np.minimum(k, span), k)
        over = np.flatnonzero(np.cumsum(k) > STEP_CHILDREN)
        later = None
        if len(over) and over[0] > 0:  # the rest waits for a later step
            later, split, k = it.take(split[over[0] :]), split[: over[0]], k[: over[0]]
        return later, self._children(it.take(split), k)

    def _children(self, it: Items, k: np.ndarray) -> Items:
        """Each item cut into ``k`` pieces: at returned points (``j - i >= 2``) or at equal
        fractions of its segment; distances at the cuts evaluated."""
        owner = np.repeat(np.arange(len(k)), k)
        m = np.arange(len(owner)) - np.repeat(np.cumsum(k) - k, k)  # 0 .. k-1 within an item
        kk, i, j = k[owner], it.i[owner], it.j[owner]
        fa, fb = it.fa[owner], it.fb[owner]
        multi = j - i >= 2

        def point(step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            at = i + (step * (j - i)) // kk
            frac = fa + (fb - fa) * step / kk
            frac = np.where(step == kk, fb, frac)
            return np.where(multi, at, i), np.where(multi, 0.0, frac)

        ci, cf = point(m + 1)  # each piece's right end; the last one is the item's end
        inner = m + 1 < kk
        d = np.empty(len(owner))
        d[~inner] = it.db
        d[inner] = self._distances(ci[inner], cf[inner], it.p[owner[inner]])
        da = np.where(m == 0, it.da[owner], np.r_[math.nan, d[:-1]])
        li, lf = point(m)
        return Items(
            li,
            np.where(multi, ci, i + 1),
            lf,
            np.where(multi, 1.0, cf),
            it.p[owner],
            da,
            d,
        )


def _unique_points(i: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct points ``(i, f)`` among the given ones, and each given point's index in them."""
    order = np.lexsort((f, i))
    si, sf = i[order], f[order]
    new = np.empty(len(i), dtype=bool)
    new[:1] = True
    new[1:] = (si[1:] != si[:-1]) | (sf[1:] != sf[:-1])
    index = np.empty(len(i), dtype=int)
    index[order] = np.cumsum(new) - 1
    return si[new], sf[new], index


def check_path(
    times: np.ndarray,
    qs: np.ndarray,
    evaluate: Evaluate,
    threshold: np.ndarray,
    weights: np.ndarray,
    pair_names: list[tuple[str, str]],
) -> PathCheck:
    """Continuous check of the motion through ``qs`` ``(N, dof)`` at ``times`` ``(N,)`` [s] (module
    docstring); ``TooLarge`` when (points / ``KEY_STEP``) x pairs exceeds ``MAX_KEY_ENTRIES``."""
    times = np.asarray(times, dtype=float)
    qs = np.asarray(qs, dtype=float)
    n, P = len(qs), len(threshold)
    if P == 0 or n == 0:
        return PathCheck(None, math.inf, None, 0)
    keys = (n - 1) // KEY_STEP + 2
    if keys * P > MAX_KEY_ENTRIES:
        raise TooLarge(
            f"checking {n} points against {P} pairs is too large (at most "
            f"{MAX_KEY_ENTRIES * KEY_STEP} points x pairs); use fewer points or obstacles",
            field=("environment",),
            extra={"limit_points_x_pairs": MAX_KEY_ENTRIES * KEY_STEP},
        )
    run = ContinuousCheck(times, qs, evaluate, threshold, weights)
    run.run()
    st = run.state
    contact = None
    if st.p >= 0:
        contact = Contact(st.t, pair_names[st.p], st.d, st.seg)
    closest = (pair_names[st.upper_p], st.upper_t) if st.upper_p >= 0 else None
    return PathCheck(contact, min(st.lower, st.upper), closest, st.count)
