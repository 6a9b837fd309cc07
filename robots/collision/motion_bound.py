"""The motion bound behind the continuous check: how fast a pair's distance can change with the joints.

Any point of shape ``g`` moves by at most ``sum_k L_kg |dq_k|`` over a linear joint step ``dq``, where
``L_kg`` bounds the distance of the shape's points from joint ``k``'s axis over all configurations:
the shape's extent from its own joint's origin (the farthest box corner, cylinder rim point or capsule
end plus radius, ``RobotCollision.shape_extent``) plus the link lengths from joint ``k`` down to it
(prismatic joints add their largest travel; a prismatic joint ``k`` itself moves it by ``|dq_k|``).
A pair's distance is 1-Lipschitz in the motion of its points, so it changes by at most
``motion_weights @ |dq|``. Joints shared by both shapes of a self pair move them rigidly together and
do not count.
"""

from __future__ import annotations

import numpy as np

from robots.collision.shapes import RobotCollision
from robots.geometry.joints import JointPlacements


def ancestors(joints: JointPlacements, j: int) -> set[int]:
    """Pinocchio joint indices from ``j`` up to (not including) the root."""
    out = set()
    while j != 0:
        out.add(j)
        j = int(joints.parents[j - 1])
    return out


def levers(
    joints: JointPlacements, geometry: RobotCollision, position_limits: np.ndarray
) -> np.ndarray:
    """``(J, G)``: lever[k, i] bounds the distance from joint ``k + 1``'s origin to any point of
    shape ``i`` (1 for a prismatic joint: it moves the shape by its own travel)."""
    J = len(joints.parents)
    link_len = np.linalg.norm(joints.p, axis=1)
    lim = np.abs(position_limits).max(axis=1)
    lever = np.zeros((J, len(geometry.links)))
    for i in range(len(geometry.links)):
        reach = geometry.shape_extent(i)
        j = int(geometry.joints[i])
        while j != 0:  # walk up: joint j's own origin is where it sits
            k = j - 1
            lever[k, i] = 1.0 if not joints.revolute[k] else reach
            reach += link_len[k] + (0.0 if joints.revolute[k] else lim[joints.q_index[k]])
            j = int(joints.parents[k])
    return lever


def motion_weights(
    joints: JointPlacements,
    geometry: RobotCollision,
    position_limits: np.ndarray,
    obs_pairs: list[tuple[int, int]],
    self_pairs: list[tuple[int, int]],
) -> np.ndarray:
    """``(P, nq)``: pair ``p``'s distance changes by at most ``W[p] @ |dq|`` [m] over a linear joint
    step ``dq`` (obstacle pairs first, then self pairs, as the checker orders them)."""
    lever = levers(joints, geometry, position_limits).T  # (G, J): shape, joint
    J, nq = len(joints.parents), len(position_limits)
    chain = np.zeros((len(geometry.links), J), dtype=bool)  # shape moved by joint
    for s in range(len(geometry.links)):
        for k in ancestors(joints, int(geometry.joints[s])):
            chain[s, k - 1] = True
    first = np.array([i for i, _ in obs_pairs] + [i for i, _ in self_pairs], dtype=int)
    second = np.array([-1] * len(obs_pairs) + [j for _, j in self_pairs], dtype=int)
    rows = np.where(chain[first], lever[first], 0.0)  # obstacle pairs: every joint moving it
    mine = chain[first] & ~np.where(second[:, None] >= 0, chain[second], False)
    theirs = np.where(second[:, None] >= 0, chain[second] & ~chain[first], False)
    selfs = second >= 0  # joints moving both shapes move them rigidly together: not counted
    rows[selfs] = np.where(mine[selfs], lever[first[selfs]], 0.0) + np.where(
        theirs[selfs], lever[second[selfs]], 0.0
    )
    W = np.zeros((len(first), nq))
    np.add.at(W.T, joints.q_index, rows.T)
    return W
