"""How core sees collisions: the ``Clearance`` Protocol, and the velocity-damper rows of the DLS QP.

``core`` never imports ``robots``: a planner gets an object satisfying ``core.kinematics.Clearance``
(in the service, ``robots.collision.CollisionChecker``) and calls it on joint configurations. The
collision check every answer goes through is ``core.collisions``.

Velocity damper (Faverjon and Tournassoud 1987; in the discrete form of mink's
``CollisionAvoidanceLimit``): for a pair at distance ``d`` with unit normal ``n`` (from the obstacle
towards the robot point) and the robot point's Jacobian ``J_p`` (3, dof), the joint velocity ``qd``
must satisfy

    n^T J_p qd >= -xi (d - d_safe) / dt

for every pair with ``d < d_influence``: one period closes at most the share ``xi`` of the margin
``d - d_safe``, so (to first order) the distance decays geometrically towards ``d_safe`` and never
crosses it. ``VelocityDampers`` is the per-tick hook of the DLS QP (``ExtraRows`` of
``core.cartesian.rate``): these rows for the pairs of a ``Clearance`` within its influence distance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from core.kinematics import Clearance

__all__ = [
    "Clearance",
    "DamperRows",
    "VelocityDampers",
    "clearance_ok",
    "linearized_clearance_rows",
    "stacked_rows",
    "velocity_damper_rows",
]


@dataclass(frozen=True)
class DamperRows:
    """Linear inequality rows ``G qd <= h`` (qpsolvers' convention) of the velocity dampers.

    Attributes:
        G: ``(m, dof)`` one row per active pair.
        h: ``(m,)`` [m/s].
        active: ``(P,)`` True for the pairs that produced a row (``d < d_influence``).
    """

    G: np.ndarray
    h: np.ndarray
    active: np.ndarray


def velocity_damper_rows(
    distances: np.ndarray,
    normals: np.ndarray,
    point_jacobians: np.ndarray,
    *,
    dt: float,
    d_safe: float,
    d_influence: float,
    xi: float = 1.0,
) -> DamperRows:
    """Rows ``-n^T J_p qd <= xi (d - d_safe) / dt`` for pairs within the influence distance.

    Args:
        distances: ``(P,)`` [m] signed distance of each pair.
        normals: ``(P, 3)`` unit normals pointing from the obstacle (or the other link) to the robot
            point; the distance grows when the robot point moves along ``n``.
        point_jacobians: ``(P, 3, dof)`` linear Jacobian of the robot's closest point of each pair
            (for a self pair: the difference of the two points' Jacobians).
        dt: Control period [s] > 0.
        d_safe: [m] the distance never to cross (>= 0 for a hard contact, the clearance otherwise).
        d_influence: [m] > d_safe: pairs farther than this give no row.
        xi: Gain in (0, 1]: the fraction of the remaining margin that may be closed per period.
    """
    d = np.asarray(distances, dtype=float).reshape(-1)
    n = np.asarray(normals, dtype=float).reshape(len(d), 3)
    Jp = np.asarray(point_jacobians, dtype=float)
    if not (dt > 0 and d_influence > d_safe and 0 < xi <= 1):
        raise ValueError("need dt > 0, d_influence > d_safe and 0 < xi <= 1")
    if Jp.ndim != 3 or Jp.shape[:2] != (len(d), 3):
        raise ValueError("point_jacobians must be (P, 3, dof)")
    active = d < d_influence
    G = -np.einsum("pi,pij->pj", n[active], Jp[active])
    h = xi * (d[active] - d_safe) / dt
    return DamperRows(G, h, active)


CLEARANCE_MARGIN = 2e-3
"""[m] The linearized clearance rows of the knot NLP ask for this much beyond each pair's threshold
(the linearization errs by the curvature of the distance over one trust-region step)."""
CLEARANCE_INFLUENCE = 0.05
"""[m] Pairs farther than this beyond the largest threshold give no linearized row."""


def linearized_clearance_rows(
    clearance: Clearance,
    qs: np.ndarray,
    *,
    margin: float = CLEARANCE_MARGIN,
    influence: float = CLEARANCE_INFLUENCE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First-order clearance constraints about the configurations ``qs`` ``(M, dof)``.

    For configuration j and every pair p closer than ``max(threshold) + influence`` there, the
    distance's gradient is ``g = n^T J_p`` (``close_pairs``), and the row asks
    ``d + g . (q_j - qs[j]) >= threshold[p] + margin``, scaled by ``1 / |g|`` (a row in meters of
    the distance's steepest direction). Pairs whose distance does not depend on the joints give no row.

    Returns:
        ``(check, G, lb)``: the configuration index ``(r,)`` of each row, ``G`` ``(r, dof)`` and
        ``lb`` ``(r,)`` [m] with the constraint ``G[i] . q_check[i] >= lb[i]``.
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    reach = float(np.max(clearance.threshold, initial=0.0)) + influence
    checks, rows, bounds = [], [], []
    for j, q in enumerate(qs):
        pairs, d, n, Jp = clearance.close_pairs(q, reach)
        if len(pairs) == 0:
            continue
        g = np.einsum("pi,pij->pj", n, Jp)
        norm = np.linalg.norm(g, axis=1)
        keep = norm > 1e-9
        g, norm = g[keep] / norm[keep, None], norm[keep]
        lb = (clearance.threshold[pairs[keep]] + margin - d[keep]) / norm + g @ q
        checks.append(np.full(len(g), j))
        rows.append(g)
        bounds.append(lb)
    if not rows:
        return np.zeros(0, dtype=int), np.zeros((0, qs.shape[1])), np.zeros(0)
    return np.concatenate(checks), np.vstack(rows), np.concatenate(bounds)


def stacked_rows(
    clearance_rows: tuple[np.ndarray, np.ndarray, np.ndarray] | None, m: int, dof: int
) -> tuple[sparse.csc_matrix | None, np.ndarray]:
    """``(W, lb)``: the rows ``(check, G, lb)`` of ``linearized_clearance_rows`` on the stacked
    configurations of ``m`` checks (check j's joints at ``dof * j`` onwards): ``W x >= lb`` for
    ``x = qs.ravel()``, ``qs`` ``(m, dof)``; ``W`` None when there are no rows."""
    if clearance_rows is None or len(clearance_rows[0]) == 0:
        return None, np.zeros(0)
    check, G, lb = clearance_rows
    r = len(check)
    cols = (dof * np.asarray(check)[:, None] + np.arange(dof)[None, :]).ravel()
    W = sparse.csc_matrix(
        (np.asarray(G, dtype=float).ravel(), (np.repeat(np.arange(r), dof), cols)),
        shape=(r, dof * m),
    )
    return W, np.asarray(lb, dtype=float)


def clearance_ok(clearance: Clearance, qs: np.ndarray, margin: float = 0.0) -> bool:
    """Every pair at least ``threshold + margin`` [m] apart at every row of ``qs`` ``(N, dof)``."""
    d = clearance.distances(np.atleast_2d(np.asarray(qs, dtype=float)))
    return bool((d >= clearance.threshold + margin).all())


TOUCH = 1e-6
"""[m] A distance this close to 0 reads "touches" in a detail."""


def approach_text(a: str, b: str, distance: float, would: bool = False) -> str:
    """How close ``a`` came to ``b`` [m] in words, for a problem's ``detail``: "a comes within
    0.0123 m of b"; "a touches b" within ``TOUCH`` of 0 (a contact located by root finding);
    "a penetrates b by 0.0021 m" below that (never "within -0.0000 m"). Three significant
    digits; ``would``: "would come", "would touch", "would penetrate"."""
    d = float(distance)
    come, touch, penetrate = (
        ("would come", "would touch", "would penetrate")
        if would
        else ("comes", "touches", "penetrates")
    )
    if abs(d) < TOUCH:
        return f"{a} {touch} {b}"
    if d < 0.0:
        return f"{a} {penetrate} {b} by {-d:.3g} m"
    return f"{a} {come} within {d:.3g} m of {b}"


DAMPER_INFLUENCE = 0.05
"""[m] Pairs closer than this beyond their threshold get a velocity-damper row."""
DAMPER_GAIN = 0.02
"""Share of the remaining margin one control period may close: with a 1 ms period the distance
decays towards the threshold with a time constant of about 50 ms at most."""
DAMPER_BUFFER = 1e-3
"""[m] The dampers hold each pair this far beyond its threshold (the returned points are joined by
straight joint segments, which may cut a little closer than the controller's ticks)."""
DAMPER_CAPACITY = 16
"""Most velocity-damper rows one tick adds (the closest pairs)."""


class VelocityDampers:
    """The per-tick extra rows ``a . qd >= b`` of the DLS QP that keep ``clearance``'s pairs apart
    (``ExtraRows`` of ``core.cartesian.rate.tick_qp``): ``velocity_damper_rows`` with each pair's
    own ``d_safe`` (its threshold plus ``buffer``) for the pairs within ``influence`` of its
    threshold, the closest ``capacity`` of them. A pair already inside its threshold gets ``a . qd >= 0`` (no further
    approach) rather than a separation speed the rate bounds may not allow.

    Args:
        clearance: The environment's distances.
        dt: Control period [s] > 0.
        influence: [m] > 0 beyond each pair's threshold.
        gain: ``xi`` of ``velocity_damper_rows``, in (0, 1].
        capacity: Most rows a tick returns.
        buffer: [m] >= 0 added to each threshold (``d_safe``).
    """

    def __init__(
        self,
        clearance: Clearance,
        dt: float,
        *,
        influence: float = DAMPER_INFLUENCE,
        gain: float = DAMPER_GAIN,
        capacity: int = DAMPER_CAPACITY,
        buffer: float = DAMPER_BUFFER,
    ) -> None:
        if not (dt > 0 and influence > buffer >= 0 and 0 < gain <= 1 and capacity >= 1):
            raise ValueError(
                "need dt > 0, influence > buffer >= 0, 0 < gain <= 1 and capacity >= 1"
            )
        self.clearance, self.dt, self.influence, self.gain = clearance, dt, influence, gain
        self.buffer = buffer
        self.capacity = int(capacity)
        # pairs are queried out to twice the influence: the motion bound then skips ticks
        self.reach = float(np.max(clearance.threshold, initial=0.0)) + 2.0 * influence
        self._ref: tuple[np.ndarray, np.ndarray] | None = None  # (q, margin lower bounds)
        self.evaluations = 0
        """Ticks that queried ``close_pairs`` (the others were far by the motion bound)."""

    def __call__(self, q: np.ndarray) -> list[tuple[np.ndarray, float]]:
        c = self.clearance
        q = np.asarray(q, dtype=float)
        if self._ref is not None:  # every pair still beyond the influence since the last query
            q_ref, m_ref = self._ref
            if (m_ref - c.motion_weights @ np.abs(q - q_ref) >= self.influence).all():
                return []
        pairs, d, n, Jp = c.close_pairs(q, self.reach)
        self.evaluations += 1
        margin = self.reach - c.threshold  # pairs not returned are at least ``reach`` apart
        margin[pairs] = d - c.threshold[pairs]
        self._ref = (q.copy(), margin)
        slack = d - c.threshold[pairs]
        near = np.flatnonzero(slack < self.influence)
        near = near[np.argsort(slack[near])][: self.capacity]
        rows: list[tuple[np.ndarray, float]] = []
        for k in near:
            thr = float(c.threshold[pairs[k]]) + self.buffer
            r = velocity_damper_rows(
                d[k : k + 1], n[k : k + 1], Jp[k : k + 1],
                dt=self.dt, d_safe=thr, d_influence=thr + self.influence, xi=self.gain,
            )  # fmt: skip
            # inside the threshold already: only forbid approaching further (always feasible, and
            # the collision check reports the contact)
            rows.extend((-g, -max(float(h), 0.0)) for g, h in zip(r.G, r.h, strict=True))
        return rows
