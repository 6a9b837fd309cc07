"""A serial chain extracted once from a pinocchio model, for fast vectorized forward kinematics.

``T_base_tool(q) = inv(T_world_base) @ prod_j (M_j @ X_j(q_j)) @ T_joint_tip``, where ``M_j`` is joint
``j``'s placement in its parent joint (``model.jointPlacements``), ``X_j`` its motion (a rotation about
a unit axis for revolute joints, a translation along it for prismatic ones, both from the joint's motion
subspace) and ``T_joint_tip`` the tip frame's placement in the last joint. ``fk_many`` evaluates it
for thousands of configurations at once with stacked numpy products; ``robots.symbolic`` walks the same
chain with CasADi. Tests check both against pinocchio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from core.errors import InvalidURDF


def _ro(a: ArrayLike) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Chain:
    """Constant data of a serial chain, root joint first.

    Attributes:
        q_index: ``(n,)`` index in ``q`` of each chain joint.
        rotations: ``(n, 3, 3)`` rotation of each joint placement in its parent joint.
        translations: ``(n, 3)`` translation of each joint placement [m].
        axes: ``(n, 3)`` unit joint axis in the joint frame.
        revolute: ``(n,)`` True for revolute, False for prismatic joints.
        T_last_tip: ``(4, 4)`` tip frame in the last chain joint.
        T_base_world: ``(4, 4)`` world (model root) in the base frame.
    """

    q_index: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray
    axes: np.ndarray
    revolute: np.ndarray
    T_last_tip: np.ndarray
    T_base_world: np.ndarray

    @classmethod
    def from_model(cls, model: pin.Model, tip_id: int, base_id: int) -> Chain:
        """Walk from the tip frame's parent joint to the root; every joint must have one dof."""
        joints = []
        j = model.frames[tip_id].parentJoint
        while j != 0:
            joints.append(j)
            j = model.parents[j]
        joints.reverse()
        rotations, translations, axes, revolute = [], [], [], []
        for j in joints:
            jm = model.joints[j]
            if jm.nq != 1 or jm.nv != 1:
                raise InvalidURDF(f"joint '{model.names[j]}' is not a one-dof joint")
            jd = jm.createData()
            jm.calc(jd, np.zeros(model.nq))
            s = np.asarray(jd.S, dtype=float).reshape(6)
            lin, ang = s[:3], s[3:]
            is_rev = bool(np.linalg.norm(ang) > 0.5)
            axes.append(ang if is_rev else lin)
            revolute.append(is_rev)
            placement = model.jointPlacements[j]
            rotations.append(placement.rotation)
            translations.append(placement.translation)
        base = model.frames[base_id]
        if base.parentJoint != 0:
            raise InvalidURDF("base_frame must be fixed to the URDF's root link")
        return cls(
            q_index=_ro([model.joints[j].idx_q for j in joints]).astype(int),
            rotations=_ro(np.reshape(rotations, (-1, 3, 3))),
            translations=_ro(np.reshape(translations, (-1, 3))),
            axes=_ro(np.reshape(axes, (-1, 3))),
            revolute=_ro(revolute).astype(bool),
            T_last_tip=_ro(model.frames[tip_id].placement.homogeneous),
            T_base_world=_ro(base.placement.inverse().homogeneous),
        )

    def __post_init__(self) -> None:
        # Per joint one (9, 3) block [M^T; (M K)^T; (M K^2)^T] (revolute; K = the axis' cross-product
        # matrix) or [M^T; 0; 0] (prismatic), applied to the transposed rotations of all N rows at
        # once: one (9, 3) @ (3, 3N) product per joint, then contiguous element-wise work.
        blocks = np.zeros((len(self.q_index), 9, 3))
        for k, (M, a) in enumerate(zip(self.rotations, self.axes, strict=True)):
            K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
            blocks[k, :3] = M.T
            if self.revolute[k]:
                blocks[k, 3:6], blocks[k, 6:] = (M @ K).T, (M @ K @ K).T
        object.__setattr__(self, "_blocks", _ro(blocks))

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        """``T_base_tool`` for each row of ``qs`` ``(N, nq)``: ``(N, 4, 4)``, meters.

        Rodrigues per joint, ``R <- R M (I + sin(q) K + (1 - cos(q)) K^2)``, on ``S[j, i, n] =
        R_n[i, j]`` (rotations transposed and stacked along the last axis, so that every product is
        one matrix product and every element-wise step runs over contiguous length-N rows).
        """
        return self._walk(qs, jacobian=False)[0]

    def fk_jacobian_many(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``T_base_tool`` ``(N, 4, 4)`` and the geometric Jacobians ``(N, 6, nq)`` in the base
        frame (linear rows first) for each row of ``qs`` ``(N, nq)``, from the same product.

        Column of joint ``k`` with axis ``z_k`` and origin ``o_k`` (base frame): revolute
        ``[z_k x (p_tip - o_k); z_k]``, prismatic ``[z_k; 0]``. Columns of joints off the chain
        are zero (pinocchio's convention).
        """
        T, J = self._walk(qs, jacobian=True)
        return T, J  # type: ignore[return-value]

    def joint_axes_many(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each chain joint's unit axis and a point on it (its origin), in the base frame, and the
        tip pose, for each row of ``qs`` ``(N, nq)``: ``(N, n, 3)``, ``(N, n, 3)`` [m], ``(N, 4, 4)``.
        For configuration labels and IK geometry (which joint axes meet or are parallel)."""
        T, _, axes, origins = self._walk_all(np.asarray(qs, dtype=float), jacobian=True)
        return axes.transpose(2, 0, 1), origins.transpose(2, 0, 1), T  # type: ignore[union-attr]

    def kinematics_many(
        self, qs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``fk_jacobian_many`` and ``joint_axes_many`` from one product: tip poses ``(N, 4, 4)``,
        Jacobians ``(N, 6, nq)``, joint axes ``(N, n, 3)`` and joint origins ``(N, n, 3)``."""
        T, J, axes, origins = self._walk_all(np.asarray(qs, dtype=float), jacobian=True)
        return T, J, axes.transpose(2, 0, 1), origins.transpose(2, 0, 1)  # type: ignore[union-attr, return-value]

    def _walk(self, qs: np.ndarray, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]:
        T, J, _, _ = self._walk_all(qs, jacobian)
        return T, J

    def _walk_all(
        self, qs: np.ndarray, jacobian: bool
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """The product of ``fk_many``, also keeping each joint's axis and origin for Jacobians."""
        qs = np.asarray(qs, dtype=float)
        n = qs.shape[0]
        S = np.repeat(self.T_base_world[:3, :3].T.reshape(3, 3, 1), n, axis=2).reshape(3, 3 * n)
        p = np.repeat(self.T_base_world[:3, 3].reshape(3, 1), n, axis=1)
        blocks: np.ndarray = self._blocks  # type: ignore[attr-defined]
        joints = len(self.q_index)
        axes = np.empty((joints, 3, n)) if jacobian else None  # z_k, base frame
        origins = np.empty((joints, 3, n)) if jacobian else None  # o_k, base frame
        for k in range(joints):
            p += (self.translations[k] @ S).reshape(3, n)
            x = qs[:, self.q_index[k]]
            if origins is not None:
                origins[k] = p
            if self.revolute[k]:
                G = (blocks[k] @ S).reshape(3, 3, 3, n)
                S = (G[0] + np.sin(x) * G[1] + (1.0 - np.cos(x)) * G[2]).reshape(3, 3 * n)
            else:
                S = blocks[k, :3] @ S
            if axes is not None:
                axes[k] = (self.axes[k] @ S).reshape(3, n)
            if not self.revolute[k]:
                p += (self.axes[k] @ S).reshape(3, n) * x
        out = np.zeros((n, 4, 4))
        out[:, :3, :3] = (self.T_last_tip[:3, :3].T @ S).reshape(3, 3, n).transpose(2, 1, 0)
        tip = p + (self.T_last_tip[:3, 3] @ S).reshape(3, n)
        out[:, :3, 3] = tip.T
        out[:, 3, 3] = 1.0
        if axes is None or origins is None:
            return out, None, None, None
        J = np.zeros((n, 6, qs.shape[1]))
        rev, pri = self.revolute, ~self.revolute
        if rev.any():
            z, r = axes[rev], tip - origins[rev]  # (R, 3, n)
            cols = self.q_index[rev]
            J[:, 0, cols] = (z[:, 1] * r[:, 2] - z[:, 2] * r[:, 1]).T
            J[:, 1, cols] = (z[:, 2] * r[:, 0] - z[:, 0] * r[:, 2]).T
            J[:, 2, cols] = (z[:, 0] * r[:, 1] - z[:, 1] * r[:, 0]).T
            J[:, 3:, cols] = z.transpose(2, 1, 0)
        if pri.any():
            J[:, :3, self.q_index[pri]] = axes[pri].transpose(2, 1, 0)
        return out, J, axes, origins
