"""IK of many poses at once: ``ik_many`` (one configuration branch along a path) and ``ik_all_many``
(every solution of each pose), batched for analytic 6R arms (one EAIK call, vectorized verification,
labels and choices), pose by pose otherwise."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robots import configurations
from robots.ik import (
    POLISH_BELOW,
    SAME,
    SINGULAR,
    TWO_PI,
    VERIFY_ORIENTATION,
    VERIFY_POSITION,
    IKSolutions,
    _polish,
    _wrap,
    ik_all,
)
from robots.ik_analytic import AnalyticIK
from robots.ik_robot import IKRobot as Robot


@dataclass(frozen=True)
class IKPath:
    """IK of a sequence of poses on one configuration branch (``ik_many``).

    Attributes:
        positions: ``(N, dof)`` joint positions [rad or m]; 2 pi turns unwrapped from the seed, so
            consecutive rows never jump by a whole turn. Rows where ``found`` is False hold the
            previous row's values.
        found: ``(N,)`` a verified solution with the configuration exists at that pose.
        within_limits: ``(N,)`` that solution is inside the joint position limits.
        configuration: The label followed (None for robots without labels: nearest the previous row).
        solver: ``"analytic"`` or ``"numeric"``.
    """

    positions: np.ndarray
    found: np.ndarray
    within_limits: np.ndarray
    configuration: str | None
    solver: str


def ik_many(
    robot: Robot, Ts: np.ndarray, seed: np.ndarray, configuration: str | None = None
) -> IKPath:
    """IK of every pose of ``Ts`` ``(N, 4, 4)`` on one branch: the configuration ``configuration``
    (default the seed's label) at every pose, verified by FK to 1e-9 m and 1e-9 rad.

    6R arms with an analytic solver: one batched EAIK call, one vectorized verification and labelling
    of all candidates, a vectorized choice per pose (no Python loop per sample). Other robots:
    damped Newton from the previous row, pose by pose (the numeric path of the sampled method).
    """
    Ts = np.asarray(Ts, dtype=float)
    seed = np.asarray(seed, dtype=float)
    n, dof = len(Ts), robot.dof
    label = configuration if configuration is not None else robot.configuration(seed)
    analytic = robot.analytic_ik
    if analytic is None or analytic.held is not None or label is None:
        return _ik_many_numeric(robot, Ts, seed, label)
    Q, owner, good = _analytic_verified(robot, analytic, Ts)
    labels = np.array(robot.configurations(Q), dtype=object) if len(Q) else np.zeros(0, object)
    match = good & (labels == label)
    found = np.zeros(n, dtype=bool)
    found[owner[match]] = True
    chosen = np.zeros((n, dof))
    # the first matching candidate of each pose (a label names one solution modulo 2 pi)
    idx = np.flatnonzero(match)
    first = np.unique(owner[idx], return_index=True)[1]
    chosen[owner[idx[first]]] = Q[idx[first]]
    # rows without a solution repeat the previous found row (or the seed)
    last = np.maximum.accumulate(np.where(found, np.arange(n), -1))
    filled = np.where((last >= 0)[:, None], chosen[np.maximum(last, 0)], seed)
    unwrapped = np.unwrap(np.vstack([seed, filled]), axis=0)[1:]
    positions = np.where(robot.revolute, unwrapped, filled)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    within = np.all((positions >= lo - 1e-12) & (positions <= hi + 1e-12), axis=1)
    return IKPath(positions, found, within & found, label, "analytic")


def _smallest_singular_values(J: np.ndarray) -> np.ndarray:
    """Smallest singular value of each square Jacobian ``(N, 6, 6)``, or +inf where it is certainly
    above ``SINGULAR``: sigma_min >= |det J| / sigma_max^5 and sigma_max <= ||J||_F, so only rows
    with |det J| < SINGULAR ||J||_F^5 get an SVD (a few of thousands)."""
    out = np.full(len(J), np.inf)
    if not len(J):
        return out
    frob = np.sqrt(np.einsum("nij,nij->n", J, J))
    maybe = np.abs(np.linalg.det(J)) < SINGULAR * np.maximum(frob, 1e-300) ** 5
    if maybe.any():
        out[maybe] = np.linalg.svd(J[maybe], compute_uv=False)[:, -1]
    return out


def pose_errors_many(robot: Robot, qs: np.ndarray, Ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``pose_errors`` with one goal per row: ``Ts`` ``(N, 4, 4)``."""
    if len(qs) == 0:
        return np.zeros(0), np.zeros(0)
    return _errors_many(robot.chain.fk_many(qs), Ts)


def _errors_many(F: np.ndarray, Ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pe = np.linalg.norm(F[:, :3, 3] - Ts[:, :3, 3], axis=1)
    E = np.einsum("nji,njk->nik", Ts[:, :3, :3], F[:, :3, :3])
    w = 0.5 * np.stack(
        [E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], 1
    )
    return pe, np.arctan2(np.linalg.norm(w, axis=1), 0.5 * (np.trace(E, axis1=1, axis2=2) - 1.0))


def _ik_many_numeric(robot: Robot, Ts: np.ndarray, seed: np.ndarray, label: str | None) -> IKPath:
    n = len(Ts)
    positions = np.zeros((n, robot.dof))
    found, within = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    previous = seed
    for i, T in enumerate(Ts):
        r = robot.ik(T, previous, position_tolerance=1e-10, orientation_tolerance=1e-10)
        ok = r.position_error <= VERIFY_POSITION and r.orientation_error <= VERIFY_ORIENTATION
        if ok and label is not None:
            ok = robot.configuration(r.positions) == label
        found[i], within[i] = ok, ok and r.within_limits
        if ok:
            previous = r.positions
        positions[i] = previous
    return IKPath(positions, found, within, label, "numeric")


def ik_all_many(robot: Robot, Ts: np.ndarray, seed: np.ndarray | None = None) -> list[IKSolutions]:
    """``ik_all`` (without ``turns`` or ``fixed_joints``) for each pose of ``Ts`` ``(N, 4, 4)``.

    Analytic 6R arms run batched: one EAIK call for all poses, then every step (verification, the
    2 pi turn nearest the seed, limits, deduplication, labels, singular values, ordering) on all
    candidates at once; the per-pose lists are split off at the end. Other robots: ``ik_all`` per pose.
    """
    Ts = np.asarray(Ts, dtype=float)
    seed = robot.home if seed is None else np.asarray(seed, dtype=float)
    analytic = robot.analytic_ik
    if analytic is None or analytic.held is not None:
        return [ik_all(robot, T, seed) for T in Ts]
    n = len(Ts)
    Q, owner, good = _analytic_verified(robot, analytic, Ts)
    Q, owner = Q[good], owner[good]
    # the 2 pi turn of each joint nearest the seed, inside the limits (rows with none are dropped)
    lo, hi, rev = robot.position_limits[:, 0], robot.position_limits[:, 1], robot.revolute
    base = Q + np.where(rev, TWO_PI * np.round((seed - Q) / TWO_PI), 0.0)
    k_lo = np.where(rev, np.ceil((lo - base - 1e-12) / TWO_PI), 0.0)
    k_hi = np.where(rev, np.floor((hi - base + 1e-12) / TWO_PI), 0.0)
    inside = (k_lo <= k_hi).all(axis=1)
    Q = np.clip(base + TWO_PI * np.clip(0.0, k_lo, k_hi), lo, hi)[inside]
    owner = owner[inside]
    # deduplicate within each pose: an earlier row of the same pose equal modulo 2 pi
    if len(Q) > 1:
        order = np.argsort(owner, kind="stable")
        Q, owner = Q[order], owner[order]
        width = int(np.bincount(owner).max())
        same = np.zeros(len(Q), dtype=bool)
        for lag in range(1, width):
            d = np.abs(_wrap(Q[lag:] - Q[:-lag], rev)).max(axis=1) < SAME
            same[lag:] |= d & (owner[lag:] == owner[:-lag])
        Q, owner = Q[~same], owner[~same]
    # nearest the seed first within each pose
    order = np.lexsort((np.linalg.norm(Q - seed, axis=1), owner))
    Q, owner = Q[order], owner[order]
    F, J, z, o = robot.chain.kinematics_many(Q)
    pe, oe = _errors_many(F, Ts[owner])
    smallest = _smallest_singular_values(J)
    fam = robot.configuration_family
    labels = (
        configurations.labels_from(fam, configurations.signs_from(fam, z, o, F))
        if fam is not None and len(Q)
        else [None] * len(Q)
    )
    bounds = np.searchsorted(owner, np.arange(n + 1))
    out = []
    for i in range(n):
        a, b = bounds[i], bounds[i + 1]
        warn: tuple[str, ...] = ()
        if b > a and smallest[a:b].min() < SINGULAR:
            warn = (
                "the pose is at or near a singularity (smallest Jacobian singular value "
                f"{smallest[a:b].min():.1e}): infinitely many solutions exist there, and the "
                "ones returned are representatives",
            )
        out.append(IKSolutions(Q[a:b], tuple(labels[a:b]), pe[a:b], oe[a:b], "analytic", warn))
    return out


def _analytic_verified(
    robot: Robot, analytic: AnalyticIK, Ts: np.ndarray
) -> tuple[np.ndarray, ...]:
    """Every analytic candidate of the poses ``Ts`` (N, 4, 4) at once: ``Q`` (M, dof), the pose
    each belongs to ``owner`` (M,), and ``good`` (M,): verified by FK to 1e-9 m / rad (candidates
    near it Newton-polished first: EAIK's least-squares answers at singular poses)."""
    rows = analytic.solve_many(Ts)
    counts = np.array([len(r) for r in rows])
    Q = np.concatenate(rows) if counts.sum() else np.zeros((0, robot.dof))
    owner = np.repeat(np.arange(len(Ts)), counts)
    pe, oe = pose_errors_many(robot, Q, Ts[owner])
    good = (pe <= VERIFY_POSITION) & (oe <= VERIFY_ORIENTATION)
    fix = ~good & (pe < POLISH_BELOW)
    if fix.any():  # rare: EAIK's least-squares answers at singular poses
        for i in np.flatnonzero(fix):
            Q[i] = _polish(robot, Ts[owner[i]], Q[i : i + 1], {})[0]
        pe, oe = pose_errors_many(robot, Q, Ts[owner])
        good = (pe <= VERIFY_POSITION) & (oe <= VERIFY_ORIENTATION)
    return Q, owner, good
