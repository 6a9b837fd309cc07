"""World placements of every joint of a serial pinocchio model for many configurations at once."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class JointPlacements:
    """The serial chain's joint placements, for all joints at once (root first)."""

    parents: np.ndarray
    R: np.ndarray  # (J, 3, 3) joint placement rotation in its parent joint
    p: np.ndarray  # (J, 3)
    axis: np.ndarray  # (J, 3)
    revolute: np.ndarray  # (J,)
    q_index: np.ndarray  # (J,)

    @classmethod
    def from_model(cls, model: pin.Model) -> JointPlacements:
        R, p, axis, rev, qi = [], [], [], [], []
        for j in range(1, model.njoints):
            jm = model.joints[j]
            jd = jm.createData()
            jm.calc(jd, pin.neutral(model))
            s = np.asarray(jd.S, dtype=float).reshape(6)
            is_rev = bool(np.linalg.norm(s[3:]) > 0.5)
            axis.append(s[3:] if is_rev else s[:3])
            rev.append(is_rev)
            R.append(model.jointPlacements[j].rotation)
            p.append(model.jointPlacements[j].translation)
            qi.append(jm.idx_q)
        return cls(
            np.array(model.parents[1:], dtype=int),
            np.reshape(R, (-1, 3, 3)),
            np.reshape(p, (-1, 3)),
            np.reshape(axis, (-1, 3)),
            np.array(rev, dtype=bool),
            np.array(qi, dtype=int),
        )

    def placements(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World rotations ``(J+1, N, 3, 3)`` and origins ``(J+1, N, 3)`` of every joint (index 0:
        the root) for each row of ``qs`` ``(N, nq)``."""
        n, J = qs.shape[0], len(self.parents)
        Rw = np.empty((J + 1, n, 3, 3))
        pw = np.empty((J + 1, n, 3))
        Rw[0], pw[0] = np.eye(3), 0.0
        for k in range(J):
            par = self.parents[k]
            flat = Rw[par].reshape(3 * n, 3)  # rows of every R: one BLAS product per constant
            Rp = flat @ self.R[k]
            pw[k + 1] = pw[par] + (flat @ self.p[k]).reshape(n, 3)
            x = qs[:, self.q_index[k]]
            a = self.axis[k]
            if self.revolute[k]:
                K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
                # Rp Rot(x) = Rp + sin(x) Rp K + (1 - cos(x)) Rp K^2 (Rodrigues)
                s_ = np.repeat(np.sin(x), 3)[:, None]
                c_ = np.repeat(1.0 - np.cos(x), 3)[:, None]
                Rw[k + 1] = (Rp + s_ * (Rp @ K) + c_ * (Rp @ (K @ K))).reshape(n, 3, 3)
            else:
                Rw[k + 1] = Rp.reshape(n, 3, 3)
                pw[k + 1] += (Rp @ a).reshape(n, 3) * x[:, None]
        return Rw, pw
