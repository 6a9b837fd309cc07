"""Configuration labels: which IK branch a joint configuration is on, computed from q alone.

Each label is a sign of a quantity that is zero exactly on a singular set, so two IK solutions of one
pose lie on different branches exactly when some sign differs, and a motion that keeps its label
never passes through that singularity (definitions also in docs/robots.md, "Configurations").
Everything is geometric (joint axes and points on them in the base frame, from ``Chain``), so inline
URDFs of the same families get the same labels.

``wrist_6r`` (6R arms with axis 2 parallel to axis 3, axes 5 and 6 meeting in a point ``c``, and
either axis 4 parallel to axis 2 (UR family) or axes 4, 5, 6 meeting in ``c`` (spherical wrist,
PUMA 560)). With ``z_k`` joint k's axis, ``o_k`` a point on it, ``w`` the point of axis 4 nearest
``c`` (``c`` itself for a spherical wrist):

- shoulder ``s = ((z_2 x z_1) . (c - o_1))``: which side of the plane through axis 1 parallel to
  axis 2 holds ``c``; ``right`` when s < 0, else ``left`` (zero: shoulder singularity).
- elbow ``e = sign(s) * (((o_3 - o_2) x (w - o_3)) . z_2)`` (sign(0) = 1): which way the arm bends at
  the elbow, seen along axis 2 (zero: stretched or folded, the elbow singularity); ``up`` when
  e >= 0, else ``down``.
- wrist ``f = (z_4 x z_6) . z_5``: sin of the wrist bend (zero: axes 4 and 6 aligned, the wrist
  singularity); ``noflip`` when f < 0, else ``flip``.

Label ``"{shoulder}-{elbow}-{wrist}"``, e.g. ``"right-up-noflip"``; 8 labels. The signs are chosen so
that the PUMA 560's labels are Corke's (Robotics Toolbox ``ikine_a`` configuration letters: ``lun``
is ``left-up-noflip``), checked in tests/robots/test_ik_all.py.

``planar_2r`` (two revolute joints moving the tip in the plane normal to axis 1): elbow
``e = ((o_2 - o_1) x (p - o_2)) . z_1`` with ``p`` the tip; ``down`` when e >= 0 (for the shipped arm
e = l1 l2 sin q2: q2 in [0, pi]), else ``up``.

Other robots have no labels (``family`` None): their IK solutions carry ``configuration: null``.
"""

from __future__ import annotations

import itertools

import numpy as np

from robots.chain import Chain

WRIST_6R = "wrist_6r"
PLANAR_2R = "planar_2r"
_PARALLEL = 1e-9
"""|z_a x z_b| below which two unit axes count as parallel (geometry at q = 0)."""
_MEET = 1e-9
"""Distance [m] below which two axes count as meeting."""

LABELS = {
    WRIST_6R: tuple(
        "-".join(parts)
        for parts in itertools.product(("right", "left"), ("up", "down"), ("noflip", "flip"))
    ),
    PLANAR_2R: ("down", "up"),
}


def _line_distance(z1, o1, z2, o2) -> float:
    n = np.cross(z1, z2)
    nn = np.linalg.norm(n)
    d = o2 - o1
    if nn < _PARALLEL:
        return float(np.linalg.norm(d - (d @ z1) * z1))
    return float(abs(d @ n) / nn)


def _parallel(a, b) -> bool:
    return bool(np.linalg.norm(np.cross(a, b)) < _PARALLEL)


def family(chain: Chain, task_space: str) -> str | None:
    """``"wrist_6r"``, ``"planar_2r"`` or None, from the chain's axes at q = 0."""
    n = len(chain.q_index)
    if not chain.revolute.all():
        return None
    if task_space == "position_xy":
        return PLANAR_2R if n == 2 else None
    if n != 6:
        return None
    z, o, _ = chain.joint_axes_many(np.zeros((1, n)))
    z, o = z[0], o[0]
    if _parallel(z[0], z[1]) or not _parallel(z[1], z[2]):
        return None
    if _parallel(z[4], z[5]) or _line_distance(z[4], o[4], z[5], o[5]) > _MEET:
        return None
    if _parallel(z[3], z[1]):
        return WRIST_6R
    c = _meeting_point(z[None, 4], o[None, 4], z[None, 5], o[None, 5])[0]
    if _line_distance(z[3], o[3], np.zeros(3), c) <= _MEET and not _parallel(z[3], z[4]):
        return WRIST_6R
    return None


def _meeting_point(za, oa, zb, ob) -> np.ndarray:
    """Midpoint of the closest points of the lines (oa + t za) and (ob + u zb), rows ``(N, 3)``."""
    d = ob - oa
    a_b = np.einsum("ij,ij->i", za, zb)
    denom = 1.0 - a_b**2
    da, db = np.einsum("ij,ij->i", d, za), np.einsum("ij,ij->i", d, zb)
    safe = np.where(denom > 1e-15, denom, 1.0)
    t = np.where(denom > 1e-15, (da - a_b * db) / safe, da)
    u = np.where(denom > 1e-15, (a_b * da - db) / safe, 0.0)
    return 0.5 * ((oa + t[:, None] * za) + (ob + u[:, None] * zb))


def _dot(a, b) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of ``(N, 3)`` arrays (cheaper than ``np.cross`` for small N)."""
    return np.column_stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ]
    )


def signs(chain: Chain, fam: str, qs: np.ndarray) -> np.ndarray:
    """The signed quantities of the family's definition for each row of ``qs`` ``(N, n)``:
    ``(N, 3)`` (s, e, f) for ``wrist_6r``, ``(N, 1)`` (e) for ``planar_2r``."""
    z, o, T = chain.joint_axes_many(np.atleast_2d(qs))
    return signs_from(fam, z, o, T)


def signs_from(fam: str, z: np.ndarray, o: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``signs`` from joint axes ``z`` and origins ``o`` ``(N, n, 3)`` and tip poses ``T``."""
    if fam == PLANAR_2R:
        e = _dot(_cross(o[:, 1] - o[:, 0], T[:, :3, 3] - o[:, 1]), z[:, 0])
        return e[:, None]
    c = _meeting_point(z[:, 4], o[:, 4], z[:, 5], o[:, 5])
    w = o[:, 3] + _dot(c - o[:, 3], z[:, 3])[:, None] * z[:, 3]
    s = _dot(_cross(z[:, 1], z[:, 0]), c - o[:, 0])
    e = np.where(s >= 0, 1.0, -1.0) * _dot(_cross(o[:, 2] - o[:, 1], w - o[:, 2]), z[:, 1])
    f = _dot(_cross(z[:, 3], z[:, 5]), z[:, 4])
    return np.column_stack([s, e, f])


def labels(chain: Chain, fam: str | None, qs: np.ndarray) -> list[str | None]:
    """The label of each row of ``qs`` ``(N, n)`` (None for every row when ``fam`` is None)."""
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    if fam is None:
        return [None] * len(qs)
    return labels_from(fam, signs(chain, fam, qs))


def labels_from(fam: str, v: np.ndarray) -> list[str | None]:
    """Labels from the signed quantities ``v`` of ``signs``."""
    table = np.array(LABELS[fam], dtype=object)
    if fam == PLANAR_2R:
        return table[(v[:, 0] < 0).astype(int)].tolist()
    # LABELS order: (right, left) x (up, down) x (noflip, flip)
    index = 4 * (v[:, 0] >= 0) + 2 * (v[:, 1] < 0) + (v[:, 2] >= 0)
    return table[index.astype(int)].tolist()


def margins(chain: Chain, fam: str | None, qs: np.ndarray) -> np.ndarray:
    """``(N,)`` the smallest |signed quantity| of each row: how far from a branch boundary (a
    singularity) it is, in the quantity's units (m^2 or dimensionless); inf without a family."""
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    if fam is None:
        return np.full(len(qs), np.inf)
    return np.abs(signs(chain, fam, qs)).min(axis=1)
