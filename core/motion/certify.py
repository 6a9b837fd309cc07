"""Certified joint paths: no contact between checked configurations, by the Clearance motion bound.

A pair's distance changes by at most ``motion_weights[p] @ |dq|`` [m] over a joint step ``dq``
(``core.clearance.Clearance``). Along a path piece whose joints move at most ``v`` [rad per unit s]
each (a straight joint segment parameterized by its arc length: ``v = |u|``, its unit direction),
the joints travel at most ``(s_b - s_a) v`` between path parameters ``s_a`` and ``s_b``, so a pair
at margins ``m_a``, ``m_b`` over its threshold at the two ends stays at least
``(m_a + m_b - B) / 2`` over it everywhere between, ``B = (s_b - s_a) w_p . v``: the distance is
at least ``m_a - w.dq(s)`` from one end and ``m_b - w.dq'(s)`` from the other, and the two motions
add up to ``B``. An interval whose bound is non-negative for every pair is proven clear; the others
are halved, their midpoints evaluated, until every interval is proven (the path is certified), or
a midpoint is closer than the threshold (a contact: the path is refused where it is), or the work
runs out (unproven: refused too). No resolution parameter: nothing is sampled and left unproven,
so no contact can slip between checked configurations. The margin required is the threshold plus
``CERTIFY_MARGIN``, which covers the distance engines' rounding.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.clearance import Clearance
from core.motion.clearance import GroupClearance

CERTIFY_MARGIN = 1e-5
"""[m] Margin beyond each threshold that a certified path keeps (distance engines' rounding)."""
MAX_LEVELS = 40
"""Most halvings of one path piece (2^-40 of it); an interval still unproven there is refused."""
MAX_EVALUATIONS = 4000
"""Most configurations one certification evaluates; a path that needs more is refused."""


@dataclass(frozen=True)
class Margins:
    """Margins [m] over ``threshold + CERTIFY_MARGIN`` of every pair at some configurations.

    Attributes:
        value: ``(K, P)``: exact where ``exact``, else a lower bound (``-inf``: nothing known).
        exact: ``(K, P)`` bool.
    """

    value: np.ndarray
    exact: np.ndarray

    @staticmethod
    def unknown(k: int, p: int) -> Margins:
        return Margins(np.full((k, p), -np.inf), np.zeros((k, p), dtype=bool))


@dataclass(frozen=True)
class Certificate:
    """Outcome of a certification.

    Attributes:
        ok: Every piece proven clear.
        evaluations: Configurations evaluated (for one or more pairs).
        failed_at: Path parameter of the first contact found, or of an interval left unproven;
            None when ``ok``.
        contact: True when ``failed_at`` is a configuration closer than a threshold (False: the
            work ran out first).
        ends: What is known at the breakpoints afterwards (to reuse for the next path through them).
        min_margin: [m] Smallest exact margin evaluated.
    """

    ok: bool
    evaluations: int
    failed_at: float | None
    contact: bool
    ends: Margins
    min_margin: float = np.inf


def margins(clearance: Clearance, qs: np.ndarray) -> np.ndarray:
    """Exact margins ``(N, P)`` [m] over ``threshold + CERTIFY_MARGIN`` at the rows of ``qs``
    ``(N, dof)`` (negative: too close)."""
    d = clearance.distances(np.atleast_2d(np.asarray(qs, dtype=float)))
    return d - (clearance.threshold + CERTIFY_MARGIN)


def certify(
    clearance: GroupClearance,
    q_at: Callable[[int, float], np.ndarray],
    s: np.ndarray,
    speed: np.ndarray,
    ends: Margins | None = None,
    *,
    max_evaluations: int = MAX_EVALUATIONS,
) -> Certificate:
    """Prove the path ``q_at(s)`` clear between its breakpoints ``s`` ``(K,)``, pair by pair.

    Runs of pieces first (``_Work.knots``: a run's pairs whose margins at its two end knots exceed
    its cumulative bound are proven for all its pieces), then piece by piece, depth first: an
    interval's pairs whose bound ``(m_a + m_b - B) / 2`` is non-negative are proven (an end not evaluated for a pair is bounded from the other end,
    ``m_b >= m_a - B``); an open pair first gets its ends evaluated exactly (that pair only),
    then the interval is halved and its midpoint evaluated for its open pairs. Pairs far from
    contact are thus never evaluated inside a piece, often not even at its ends.

    Args:
        clearance: The distances, thresholds and motion weights.
        q_at: The configuration ``(dof,)`` on piece k at path parameter s: ``q_at(k, s)``.
        s: Increasing breakpoints; piece k runs from ``s[k]`` to ``s[k + 1]``.
        speed: ``(K - 1, dof)``: on piece k every joint j moves at most ``speed[k, j]`` per unit s.
        ends: What is known at the breakpoints (default nothing).
        max_evaluations: Work bound; a path needing more is refused (``contact`` False).
    """
    s = np.asarray(s, dtype=float)
    P = len(clearance.threshold)
    known = ends if ends is not None else Margins.unknown(len(s), P)
    value, exact = np.array(known.value, dtype=float), np.array(known.exact, dtype=bool)
    rate = np.asarray(speed, dtype=float) @ np.asarray(clearance.motion_weights, dtype=float).T
    thr = np.asarray(clearance.threshold, dtype=float) + CERTIFY_MARGIN
    work = _Work(clearance, q_at, thr, max_evaluations)
    given = exact & (value < 0)
    if given.any():
        return work.result(False, value, exact, float(s[given.any(axis=1)][0]), True)
    failed = work.knots(s, rate, value, exact) if len(s) > 1 else None
    if failed is not None:
        return work.result(False, value, exact, *failed)
    return work.result(True, value, exact)


class _Work:
    """The evaluations of one certification."""

    def __init__(
        self,
        clearance: GroupClearance,
        q_at: Callable[[int, float], np.ndarray],
        thr: np.ndarray,
        budget: int,
    ) -> None:
        self.clearance, self.q_at, self.thr, self.budget = clearance, q_at, thr, budget
        self.count, self.low, self.k = 0, np.inf, 0

    def result(
        self,
        ok: bool,
        value: np.ndarray,
        exact: np.ndarray,
        at: float | None = None,
        contact: bool = False,
    ) -> Certificate:
        return Certificate(ok, self.count, at, contact, Margins(value, exact), self.low)

    def evaluate(self, s: float, m: np.ndarray, e: np.ndarray, pairs: np.ndarray) -> bool:
        """Exact margins of ``pairs`` at ``s`` into ``m``, ``e`` (in place); False on contact."""
        q = self.q_at(self.k, s)
        m[pairs] = self.clearance.pair_distances(q, pairs) - self.thr[pairs]
        e[pairs] = True
        self.count += 1
        low = float(m[pairs].min())
        self.low = min(self.low, low)
        return low >= 0

    def knots(
        self, s: np.ndarray, rate: np.ndarray, value: np.ndarray, exact: np.ndarray
    ) -> tuple[float, bool] | None:
        """Prove every piece, runs of pieces at once: over the knots ``i`` to ``j`` a pair moves
        at most its cumulative bound ``B`` (the sum of its pieces'), so margins at the two knots
        with ``m_i + m_j >= B`` prove the whole run for it. Depth first: an open run gets its end
        knots evaluated (its open pairs), then splits at its middle knot (bounded from both
        ends); a single piece is bisected (``piece``). ``value``, ``exact`` ``(K, P)`` are
        updated in place. None, or ``(s, contact)`` where it failed."""
        steps = np.diff(s)[:, None] * rate
        cum = np.vstack([np.zeros((1, rate.shape[1])), np.cumsum(steps, axis=0)])
        stack = [(0, len(s) - 1)]
        while stack:
            i, j = stack.pop()
            if j == i + 1:
                self.k = i
                failed = self.piece(s[i], s[j], rate[i], value[i], exact[i], value[j], exact[j])
                if failed is not None:
                    return failed
                continue
            B = cum[j] - cum[i]
            ma, mb = value[i], value[j]
            np.maximum(ma, mb - B, out=ma)
            np.maximum(mb, ma - B, out=mb)
            open_ = ma + mb < B
            if not open_.any():
                continue
            for k, at, m_, e_ in ((i, s[i], ma, exact[i]), (j - 1, s[j], mb, exact[j])):
                need = np.flatnonzero(open_ & ~e_)
                if len(need):
                    if self.count >= self.budget:
                        return s[i], False
                    self.k = k
                    if not self.evaluate(at, m_, e_, need):
                        return at, True
            open_ = ma + mb < B
            if not open_.any():
                continue
            m = (i + j) // 2
            np.maximum(value[m], np.maximum(ma - (cum[m] - cum[i]), mb - (cum[j] - cum[m])),
                       out=value[m])  # fmt: skip
            stack.append((m, j))
            stack.append((i, m))
        return None

    def piece(
        self,
        s0: float,
        s1: float,
        rate: np.ndarray,
        m0: np.ndarray,
        e0: np.ndarray,
        m1: np.ndarray,
        e1: np.ndarray,
    ) -> tuple[float, bool] | None:
        """Prove one piece (the margins at its ends are updated in place): None, or
        ``(s, contact)`` where it failed."""
        stack = [(s0, s1, m0, e0, m1, e1, 0)]
        while stack:
            sa, sb, ma, ea, mb, eb, depth = stack.pop()
            B = (sb - sa) * rate
            np.maximum(ma, mb - B, out=ma)  # each end bounds the other (exact values unchanged)
            np.maximum(mb, ma - B, out=mb)
            open_ = ma + mb < B
            if not open_.any():
                continue
            for s_, m_, e_ in ((sa, ma, ea), (sb, mb, eb)):
                need = np.flatnonzero(open_ & ~e_)
                if len(need):
                    if self.count >= self.budget:
                        return sa, False
                    if not self.evaluate(s_, m_, e_, need):
                        return s_, True
            open_ = ma + mb < B
            if not open_.any():
                continue
            if depth >= MAX_LEVELS or self.count >= self.budget:
                return sa, False
            sm = (sa + sb) / 2
            mm = np.maximum(ma, mb) - B / 2
            em = np.zeros(len(mm), dtype=bool)
            if not self.evaluate(sm, mm, em, np.flatnonzero(open_)):
                return sm, True
            stack.append((sm, sb, mm, em, mb, eb, depth + 1))
            stack.append((sa, sm, ma, ea, mm, em, depth + 1))
        return None


def polyline(
    knots: np.ndarray,
) -> tuple[Callable[[int, float], np.ndarray], np.ndarray, np.ndarray]:
    """``(q_at, s, speed)`` of the straight joint segments through ``knots`` ``(K, dof)``, with s the
    joint-space arc length (zero-length segments kept as pieces of zero length)."""
    knots = np.asarray(knots, dtype=float)
    steps = np.diff(knots, axis=0)
    length = np.linalg.norm(steps, axis=1)
    s = np.concatenate([[0.0], np.cumsum(length)])
    speed = np.abs(steps) / np.where(length > 0, length, 1.0)[:, None]
    inverse = 1.0 / np.where(length > 0, length, np.inf)

    def q_at(k: int, x: float) -> np.ndarray:
        return knots[k] + ((x - s[k]) * inverse[k]) * steps[k]

    return q_at, s, speed


def certify_polyline(
    clearance: GroupClearance,
    knots: np.ndarray,
    ends: Margins | None = None,
    *,
    max_evaluations: int = MAX_EVALUATIONS,
) -> Certificate:
    """``certify`` the straight joint segments through ``knots`` ``(K, dof)`` (what is known at the
    knots: ``ends``); ``failed_at`` is joint-space arc length from the first knot."""
    q_at, s, speed = polyline(knots)
    return certify(clearance, q_at, s, speed, ends, max_evaluations=max_evaluations)


PROBE_STEP = 0.1
"""[rad] Spacing of the quick yes/no check that precedes a certification (``probably_clear``)."""
CACHE_STATES = 50_000
"""Most configurations whose margins one ``Certifier`` remembers (bounds its memory)."""


class Certifier:
    """Certification with a memory: what is known at each configuration met so far is reused by
    the next path through it (a search tree's states, a path's knots).

    Args:
        clearance: The request's clearance.
        max_evaluations: Work bound of one ``path_ok`` / ``edge_ok`` question.

    Attributes:
        evaluations: Configurations evaluated so far (for one pair or more).
    """

    def __init__(self, clearance: GroupClearance, max_evaluations: int = MAX_EVALUATIONS) -> None:
        self.clearance, self.max_evaluations = clearance, max_evaluations
        self.pairs = len(clearance.threshold)
        self.evaluations = 0
        self._known: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def known(self, qs: np.ndarray) -> Margins:
        """What is known at the rows of ``qs`` ``(K, dof)``."""
        value = np.full((len(qs), self.pairs), -np.inf)
        exact = np.zeros((len(qs), self.pairs), dtype=bool)
        for i, q in enumerate(qs):
            hit = self._known.get(np.asarray(q, dtype=float).tobytes())
            if hit is not None:
                value[i], exact[i] = hit
        return Margins(value, exact)

    def remember(self, qs: np.ndarray, ends: Margins) -> None:
        if len(self._known) + len(qs) > CACHE_STATES:
            self._known.clear()
        for i, q in enumerate(qs):
            self._known[np.asarray(q, dtype=float).tobytes()] = (ends.value[i], ends.exact[i])

    def state_margins(self, q: np.ndarray) -> np.ndarray:
        """Exact margins ``(P,)`` [m] at ``q`` (remembered)."""
        q = np.asarray(q, dtype=float)
        hit = self._known.get(q.tobytes())
        if hit is not None and hit[1].all():
            return hit[0]
        m = margins(self.clearance, q)[0]
        self.evaluations += 1
        self.remember(q[None], Margins(m[None], np.ones((1, self.pairs), dtype=bool)))
        return m

    def state_ok(self, q: np.ndarray) -> bool:
        """Every pair at least ``CERTIFY_MARGIN`` beyond its threshold at ``q`` (exact margins,
        remembered)."""
        return bool((self.state_margins(q) >= 0).all())

    def state_clear(self, q: np.ndarray, margin: float = 0.0) -> bool:
        """The fast yes/no of ``state_ok`` with ``margin`` [m] more (``GroupClearance.collides``:
        no distances, nothing remembered)."""
        self.evaluations += 1
        return not self.clearance.collides(q, CERTIFY_MARGIN + margin)

    def first_contact(
        self, knots: np.ndarray, resolution: float = PROBE_STEP
    ) -> tuple[int, float] | None:
        """A quick probe before certifying: ``state_clear`` at points at most ``resolution``
        [rad] apart along the segments through ``knots`` (each segment's middle points first):
        ``(segment, fraction)`` of the first configuration found in contact (a sure no), or
        None (the path still needs ``path``)."""
        knots = np.asarray(knots, dtype=float)
        for k, (a, b) in enumerate(itertools.pairwise(knots)):
            n = int(np.ceil(np.linalg.norm(b - a) / resolution))
            for t in _middle_first(n):
                if not self.state_clear(a + t * (b - a)):
                    return k, t
        return None

    def probably_clear(self, knots: np.ndarray, resolution: float = PROBE_STEP) -> bool:
        """No contact found by ``first_contact``."""
        return self.first_contact(knots, resolution) is None

    def path(self, knots: np.ndarray, max_evaluations: int | None = None) -> Certificate:
        """``certify_polyline`` through ``knots`` ``(K, dof)`` with what is known at them."""
        knots = np.asarray(knots, dtype=float)
        budget = self.max_evaluations if max_evaluations is None else max_evaluations
        cert = certify_polyline(self.clearance, knots, self.known(knots), max_evaluations=budget)
        self.evaluations += cert.evaluations
        self.remember(knots, cert.ends)
        return cert

    def edge_ok(self, a: np.ndarray, b: np.ndarray) -> bool:
        return self.path(np.vstack([a, b])).ok


def _middle_first(n: int) -> list[float]:
    """Fractions i / n of a segment for i = 1 .. n - 1 (its interior points), in the order of a
    breadth-first bisection (the middle first: a contact is usually found after few of them)."""
    if n < 2:
        return []
    out: list[float] = []
    seen: set[int] = set()
    level = 2
    while len(out) < n - 1:
        for j in range(1, level, 2):
            i = round(j * n / level)
            if 0 < i < n and i not in seen:
                seen.add(i)
                out.append(i / n)
        level *= 2
        if level > 4 * n:
            out.extend(i / n for i in range(1, n) if i not in seen)
            break
    return out
