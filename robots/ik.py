"""Every IK solution of a pose: the solver dispatch behind ``Robot.ik_all`` (``robots.ik_batch``
holds the batched forms behind ``Robot.ik_many`` and ``Robot.ik_all_many``).

- ``analytic``: EAIK (``robots.ik_analytic``) for 6R arms it can decompose, and for 7R arms with the
  redundant joint held; the closed form of the planar 2-link arm (``robots.ik_numeric.planar_2r``).
- ``numeric``: damped Newton (``robots.ik_numeric``) from the seed, home and ``NUMERIC_SEEDS``
  fixed pseudo-random seeds, with the redundant joints held.

Whatever solves, each candidate is verified by forward kinematics of the robot's own model
(``Chain.fk_many``, tested equal to pinocchio) to ``VERIFY_POSITION`` [m] and ``VERIFY_ORIENTATION``
[rad] (candidates just outside get a few Newton steps first); the survivors are deduplicated modulo
2 pi, moved by whole turns into the joint limits (the turn nearest the seed, or every turn with
``turns``), labelled (``robots.configurations``) and sorted nearest the seed first.

``search`` (one solution, numeric, from several seeds) is re-exported for the existing callers.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from core.errors import InputError, JointLimit
from robots import configurations
from robots.ik_numeric import (
    planar_2r_geometry,
    search,  # noqa: F401  (re-export for existing callers)
)
from robots.ik_robot import IKRobot as Robot

TWO_PI = 2.0 * math.pi
VERIFY_POSITION = 1e-9
"""[m]: largest tip position error of a returned solution."""
VERIFY_ORIENTATION = 1e-9
"""[rad]: largest tip orientation error of a returned solution."""
POLISH_BELOW = 1e-3
"""[m]: candidates with a position error below this that fail verification get Newton steps (EAIK's
least-squares answers at a singular pose reach the point but may miss the orientation by a wrist
turn, e.g. q4 + q6 of a UR arm at q5 = 0)."""
SAME = 1e-6
"""[rad or m]: two solutions closer than this in every joint (modulo 2 pi) are one."""
SINGULAR = 1e-6
"""Smallest Jacobian singular value below which a solution is reported near-singular."""
NEAR = 1e-3
"""[rad or m]: two verified solutions with the same configuration label closer than this in every
joint are one. At a singular pose the numeric search's seeds converge to points up to ~sqrt(1e-9)
apart (an inline planar arm stretched out gave four "solutions" within 6e-6 rad, two per label);
genuinely distinct solutions of one label exist only across 2 pi turns."""
NUMERIC_SEEDS = 24
"""Pseudo-random seeds of the numeric all-solutions search, besides the request seed and home."""
MAX_TURN_VARIANTS = 4096
"""Most solutions ``turns`` may return (continuous joints of inline URDFs have ~3,000 turns each)."""


@dataclass(frozen=True)
class IKSolutions:
    """Every verified IK solution of one pose, nearest the seed first.

    Attributes:
        positions: ``(k, dof)`` joint positions [rad or m], inside the limits.
        configurations: One label per solution (None for robots without labels).
        position_errors: ``(k,)`` tip position error [m] (<= 1e-9).
        orientation_errors: ``(k,)`` orientation error [rad] (<= 1e-9; 0 for ``position_xy``).
        solver: ``"analytic"`` or ``"numeric"``.
        warnings: Human-readable notes (near-singular pose: the solutions are representatives).
        outside_limits: Distinct solutions (modulo 2 pi) that reproduce the pose but lie outside the
            joint limits in every turn (0 when none were dropped for that).
    """

    positions: np.ndarray
    configurations: tuple[str | None, ...]
    position_errors: np.ndarray
    orientation_errors: np.ndarray
    solver: str
    warnings: tuple[str, ...] = ()
    outside_limits: int = 0

    def __len__(self) -> int:
        return len(self.positions)


def pose_errors(robot: Robot, qs: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tip position [m] and orientation [rad] errors of each row of ``qs`` from ``T`` (x, y only for
    ``position_xy``), vectorized."""
    return _errors(robot, robot.chain.fk_many(qs), T)


def _errors(robot: Robot, Ts: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if robot.task_space == "position_xy":
        return np.linalg.norm(Ts[:, :2, 3] - T[:2, 3], axis=1), np.zeros(len(Ts))
    pe = np.linalg.norm(Ts[:, :3, 3] - T[:3, 3], axis=1)
    E = np.einsum("ji,njk->nik", T[:3, :3], Ts[:, :3, :3])  # R_goal^T R
    w = 0.5 * np.stack(
        [E[:, 2, 1] - E[:, 1, 2], E[:, 0, 2] - E[:, 2, 0], E[:, 1, 0] - E[:, 0, 1]], 1
    )
    s, c = np.linalg.norm(w, axis=1), 0.5 * (np.trace(E, axis1=1, axis2=2) - 1.0)
    return pe, np.arctan2(s, c)


def held_values(
    robot: Robot, seed: np.ndarray, fixed_joints: dict[str, float] | None
) -> dict[int, float]:
    """Joint index -> value for the robot's redundant joints: ``fixed_joints`` (422 ``validation``
    for a joint that is not redundant, ``joint_limit`` outside its limits), else the seed's."""
    redundant = robot.redundant_joints
    held = {robot.joint_names.index(n): float(seed[robot.joint_names.index(n)]) for n in redundant}
    for name, value in (fixed_joints or {}).items():
        if name not in robot.joint_names:
            raise InputError(
                f"{robot.name} has no joint of that name",
                field=("fixed_joints", name),
                extra={"redundant_joints": list(redundant)},
            )
        if name not in redundant:
            raise InputError(
                "only the robot's redundant joints can be fixed",
                field=("fixed_joints", name),
                extra={"redundant_joints": list(redundant)},
            )
        j = robot.joint_names.index(name)
        lo, hi = robot.position_limits[j]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise JointLimit(
                f"fixed_joints holds joint '{name}' outside its position limits",
                field=("fixed_joints", name),
                joint=j,
                extra={"joint_name": name, "limits": [float(lo), float(hi)]},
            )
        held[j] = float(value)
    return held


def _candidates(robot: Robot, T: np.ndarray, seed: np.ndarray, held: dict[int, float]):
    """(candidate rows, solver name) before verification."""
    analytic = robot.analytic_ik
    if analytic is not None:
        value = None if analytic.held is None else held[analytic.held]
        try:
            return np.array(analytic.solve(T, value)), "analytic"
        except (RuntimeError, ValueError):  # EAIK refusing a held value: solve numerically
            pass
    if robot.planar_closed_form is not None:
        q = robot.planar_closed_form(T[:2, 3], seed)[0]
        return np.array([q, _planar_mirror(robot, q)]), "analytic"
    return _numeric(robot, T, seed, held), "numeric"


def _planar_mirror(robot: Robot, q: np.ndarray) -> np.ndarray:
    """The other elbow branch of a planar 2-link arm reaching the same point: the arm mirrored about
    the line from joint 1 to the tip (link lengths and angle offsets from the chain at q = 0, a
    tool point included: ``planar_2r_geometry``)."""
    geometry = planar_2r_geometry(robot.chain)
    if geometry is None:
        return q
    _, l1, l2, offset = geometry
    q2 = q[1] + offset[1]
    q1 = q[0] + 2.0 * math.atan2(l2 * math.sin(q2), l1 + l2 * math.cos(q2))
    return np.array([q1, -q2 - offset[1]])


def _numeric(robot: Robot, T: np.ndarray, seed: np.ndarray, held: dict[int, float]) -> np.ndarray:
    lower, upper = robot.position_limits[:, 0].copy(), robot.position_limits[:, 1].copy()
    for j, v in held.items():
        lower[j] = upper[j] = v
    rng = np.random.default_rng(0)
    lo, hi = np.maximum(lower, -math.pi), np.minimum(upper, math.pi)
    lo, hi = np.where(lo <= hi, lo, lower), np.where(lo <= hi, hi, upper)
    starts = np.vstack([seed, robot.home, rng.uniform(lo, hi, (NUMERIC_SEEDS, robot.dof))])
    for j, v in held.items():
        starts[:, j] = v
    limits = (lower, upper, robot.revolute)
    found = []
    for start in starts:
        r = robot.ik_from(T, start, limits, max_iterations=100, tolerance=1e-11)
        if r.position_error <= POLISH_BELOW and r.orientation_error <= POLISH_BELOW:
            found.append(r.positions)
    return np.array(found).reshape(-1, robot.dof)


def _polish(robot: Robot, T: np.ndarray, qs: np.ndarray, held: dict[int, float]) -> np.ndarray:
    lower, upper = robot.position_limits[:, 0].copy(), robot.position_limits[:, 1].copy()
    for j, v in held.items():
        lower[j] = upper[j] = v
    limits = (lower, upper, robot.revolute)
    return np.array(
        [
            robot.ik_from(T, q, limits, max_iterations=50, tolerance=1e-12, respect_limits=False)[0]
            for q in qs
        ]
    ).reshape(-1, robot.dof)


def _verified(robot: Robot, T: np.ndarray, Q: np.ndarray, held: dict[int, float]) -> np.ndarray:
    """The candidate rows that reproduce ``T`` to ``VERIFY_POSITION`` / ``VERIFY_ORIENTATION`` (near
    misses polished first) with the held joints at their values."""
    if not len(Q):
        return Q
    pe, oe = pose_errors(robot, Q, T)
    bad = (pe > VERIFY_POSITION) | (oe > VERIFY_ORIENTATION)
    fix = bad & (pe < POLISH_BELOW)
    if fix.any():
        Q = Q.copy()
        Q[fix] = _polish(robot, T, Q[fix], held)
        pe, oe = pose_errors(robot, Q, T)
    good = (pe <= VERIFY_POSITION) & (oe <= VERIFY_ORIENTATION)
    for j, v in held.items():
        good &= np.abs(Q[:, j] - v) <= 1e-12
    return Q[good]


def _wrap(d: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """Differences with revolute components wrapped into [-pi, pi)."""
    return np.where(revolute, (d + math.pi) % TWO_PI - math.pi, d)


def _dedupe(qs: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """Rows kept in order, each dropped when an earlier row equals it modulo 2 pi (within ``SAME``)."""
    if len(qs) < 2:
        return qs
    same = np.abs(_wrap(qs[:, None] - qs[None], revolute)).max(axis=2) < SAME
    return qs[np.argmax(same, axis=1) == np.arange(len(qs))]


def _turns(
    qs: np.ndarray, seed: np.ndarray, limits: np.ndarray, revolute: np.ndarray, every: bool
) -> np.ndarray:
    """Each row moved by whole turns (revolute joints) into the limits: the variant nearest ``seed``
    per joint, or (``every``) every variant; rows with no variant inside the limits are dropped."""
    lo, hi = limits[:, 0], limits[:, 1]
    base = qs + np.where(revolute, TWO_PI * np.round((seed - qs) / TWO_PI), 0.0)
    k_lo = np.where(revolute, np.ceil((lo - base - 1e-12) / TWO_PI), 0.0)
    k_hi = np.where(revolute, np.floor((hi - base + 1e-12) / TWO_PI), 0.0)
    ok = (k_lo <= k_hi).all(axis=1) & (
        revolute | ((base >= lo - 1e-12) & (base <= hi + 1e-12))
    ).all(axis=1)
    base, k_lo, k_hi = base[ok], k_lo[ok], k_hi[ok]
    if not every:
        k = np.clip(0.0, k_lo, k_hi)
        return np.clip(base + TWO_PI * k, lo, hi)
    count = np.prod(k_hi - k_lo + 1, axis=1).sum() if len(base) else 0
    if count > MAX_TURN_VARIANTS:
        raise InputError(
            f"turns would return {int(count)} solutions (at most {MAX_TURN_VARIANTS}): the joint "
            "ranges allow too many whole turns",
            field=("turns",),
        )
    out = []
    for q, a, b in zip(base, k_lo, k_hi, strict=True):
        ranges = [range(int(x), int(y) + 1) for x, y in zip(a, b, strict=True)]
        for ks in itertools.product(*ranges):
            out.append(np.clip(q + TWO_PI * np.array(ks, dtype=float), lo, hi))
    return np.array(out).reshape(-1, qs.shape[1])


def ik_all(
    robot: Robot,
    T_base_tool: np.ndarray,
    seed: np.ndarray | None = None,
    fixed_joints: dict[str, float] | None = None,
    turns: bool = False,
) -> IKSolutions:
    """Every verified solution of ``T_base_tool`` inside the limits (see the module docstring).

    Args:
        seed: ``(dof,)`` [rad or m], default ``robot.home``; solutions are sorted by distance to it.
        fixed_joints: Joint name -> value for redundant joints (default: the seed's value).
        turns: Also every 2 pi variant of each solution within the limits.
    """
    T = np.asarray(T_base_tool, dtype=float)
    seed = robot.home if seed is None else np.asarray(seed, dtype=float)
    if seed.shape != (robot.dof,) or not np.isfinite(seed).all():
        raise InputError(f"seed needs {robot.dof} finite values, one per joint", field=("seed",))
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise InputError("IK needs a finite 4x4 pose", field=("pose",))
    held = held_values(robot, seed, fixed_joints)
    Q, solver = _candidates(robot, T, seed, held)
    Q = _dedupe(_verified(robot, T, Q, held), robot.revolute)
    inside = _turns(Q, seed, robot.position_limits, robot.revolute, False)
    if not len(inside) and solver == "analytic":
        # At a singular pose the closed form returns representatives of a continuum of solutions,
        # which may all lie outside the limits while others inside exist (an iiwa stretched out
        # at q = 0, its home: "reachable only with joint 2 outside its limits"). The numeric
        # search, seeded at the seed and home, finds those.
        found = _verified(robot, T, _numeric(robot, T, seed, held), held)
        Q = _dedupe(np.vstack([Q, found]), robot.revolute)
        inside = _turns(Q, seed, robot.position_limits, robot.revolute, False)
    outside = len(Q) - len(inside)
    Q = _turns(Q, seed, robot.position_limits, robot.revolute, True) if turns else inside
    return solutions(robot, T, Q, seed, solver, outside)


def solutions(
    robot: Robot, T: np.ndarray, Q: np.ndarray, seed: np.ndarray, solver: str, outside: int = 0
) -> IKSolutions:
    """``IKSolutions`` of verified, distinct rows ``Q`` ``(k, dof)`` inside the limits: nearest the
    seed first, with their errors, labels and a warning near a singularity (``outside``: solutions
    dropped for the limits, reported as such)."""
    warnings: list[str] = []
    order = np.argsort(np.linalg.norm(Q - seed, axis=1), kind="stable")
    Q = Q[order]
    if not len(Q):
        return IKSolutions(Q, (), np.zeros(0), np.zeros(0), solver, (), outside)
    F, J, z, o = robot.chain.kinematics_many(Q)  # one product: errors, singular values, labels
    pe, oe = _errors(robot, F, T)
    smallest = np.linalg.svd(J[:, robot.task_rows], compute_uv=False)[:, -1]
    if robot.dof < len(robot.task_rows):
        smallest = np.zeros(len(Q))
    if smallest.min() < SINGULAR:
        warnings.append(
            "the pose is at or near a singularity (smallest Jacobian singular value "
            f"{smallest.min():.1e}): infinitely many solutions exist there, and the ones "
            "returned are representatives"
        )
    fam = robot.configuration_family
    labels = (
        tuple(configurations.labels_from(fam, configurations.signs_from(fam, z, o, F)))
        if fam is not None
        else (None,) * len(Q)
    )
    keep = _distinct_per_label(Q, labels)
    labels = tuple(label for label, k in zip(labels, keep, strict=True) if k)
    return IKSolutions(Q[keep], labels, pe[keep], oe[keep], solver, tuple(warnings), outside)


def _distinct_per_label(Q: np.ndarray, labels: tuple[str | None, ...]) -> np.ndarray:
    """``(k,)`` mask keeping each row unless an earlier kept row has its label and lies within
    ``NEAR`` of it in every joint (no wrapping: 2 pi variants from ``turns`` stay)."""
    keep = np.ones(len(Q), dtype=bool)
    kept: dict[str | None, list[int]] = {}
    for i, label in enumerate(labels):
        rows = kept.setdefault(label, [])
        if rows and (np.abs(Q[rows] - Q[i]).max(axis=1) < NEAR).any():
            keep[i] = False
        else:
            rows.append(i)
    return keep
