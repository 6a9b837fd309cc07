"""World placements of every joint of a serial pinocchio model for many configurations at once.

Joint ``k`` (revolute about unit axis ``a``) sits at ``R_k``, ``p_k`` in its parent joint and turns by
``x``: Rodrigues' ``Rot(x) = a a^T + cos x (I - a a^T) + sin x [a]x``, so its world rotation is the
sum of ``R_parent @ R_k a a^T``, ``cos x R_parent @ R_k (I - a a^T)`` and ``sin x R_parent @ R_k
[a]x``, and its origin ``p_parent + R_parent p_k``: a few matrix products per joint for every
configuration at once (``mix``: the constant blocks, contiguous so that BLAS takes them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class JointPlacements:
    """The serial chain's joint placements, for all joints at once (root first).

    Attributes:
        parents: ``(J,)`` parent joint index (pinocchio's: 0 is the root).
        R, p: ``(J, 3, 3)``, ``(J, 3)`` joint placement in its parent joint [m].
        axis: ``(J, 3)`` unit axis in the joint frame.
        revolute: ``(J,)``; prismatic joints translate along ``axis``.
        q_index: ``(J,)`` index in ``q`` of each joint.
        mix: ``(J, 3, 3, 3)``: per joint, ``R a a^T``, ``R (I - a a^T)``, ``R [a]x`` (revolute), or
            ``R`` and, in the first column of the second block, ``R a`` (prismatic: the direction
            it translates along).
    """

    parents: np.ndarray
    R: np.ndarray
    p: np.ndarray
    axis: np.ndarray
    revolute: np.ndarray
    q_index: np.ndarray
    mix: np.ndarray

    @classmethod
    def from_model(cls, model: pin.Model) -> JointPlacements:
        R, p, axis, rev, qi, mix = [], [], [], [], [], []
        for j in range(1, model.njoints):
            jm = model.joints[j]
            jd = jm.createData()
            jm.calc(jd, pin.neutral(model))
            s = np.asarray(jd.S, dtype=float).reshape(6)
            is_rev = bool(np.linalg.norm(s[3:]) > 0.5)
            a = s[3:] if is_rev else s[:3]
            Rk = np.array(model.jointPlacements[j].rotation)
            pk = np.array(model.jointPlacements[j].translation)
            M = np.zeros((3, 3, 3))
            if is_rev:
                K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
                M[0] = Rk @ np.outer(a, a)
                M[1] = Rk @ (np.eye(3) - np.outer(a, a))
                M[2] = Rk @ K
            else:
                M[0] = Rk
                M[1, :, 0] = Rk @ a  # the translation direction in the parent frame
            axis.append(a)
            rev.append(is_rev)
            R.append(Rk)
            p.append(pk)
            qi.append(jm.idx_q)
            mix.append(M)
        return cls(
            np.array(model.parents[1:], dtype=int),
            np.reshape(R, (-1, 3, 3)),
            np.reshape(p, (-1, 3)),
            np.reshape(axis, (-1, 3)),
            np.array(rev, dtype=bool),
            np.array(qi, dtype=int),
            np.reshape(mix, (-1, 3, 3, 3)),
        )

    def placements(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World rotations ``(J+1, N, 3, 3)`` and origins ``(J+1, N, 3)`` of every joint (index 0:
        the root) for each row of ``qs`` ``(N, nq)``."""
        n, J = qs.shape[0], len(self.parents)
        Rw = np.empty((J + 1, n, 3, 3))
        pw = np.empty((J + 1, n, 3))
        Rw[0], pw[0] = np.eye(3), 0.0
        x = qs[:, self.q_index]  # (n, J)
        for k in range(J):
            par, M = self.parents[k], self.mix[k]
            flat = Rw[par].reshape(3 * n, 3)  # the rows of every R: one BLAS product per block
            pw[k + 1] = pw[par] + (flat @ self.p[k]).reshape(n, 3)
            if self.revolute[k]:
                # each configuration's cos and sin over its 3 x 3 block: a product of equal shapes
                # is far faster than one broadcast over rows of 3
                c = np.repeat(np.cos(x[:, k]), 9).reshape(3 * n, 3)
                s = np.repeat(np.sin(x[:, k]), 9).reshape(3 * n, 3)
                R = flat @ M[0]
                R += c * (flat @ M[1])
                R += s * (flat @ M[2])
                Rw[k + 1] = R.reshape(n, 3, 3)
            else:
                Rw[k + 1] = (flat @ M[0]).reshape(n, 3, 3)
                pw[k + 1] += (flat @ M[1, :, 0]).reshape(n, 3) * x[:, k, None]
        return Rw, pw
