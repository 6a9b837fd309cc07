"""Joint caps on the path speed: how fast s may advance so the joints keep their limits."""

from __future__ import annotations

import numpy as np


def joint_speed_cap(dq_ds: np.ndarray, velocity_limits: np.ndarray) -> np.ndarray:
    """Largest s' [1/s] at each sample so that |dq/ds| s' <= the joint velocity limits.

    Args:
        dq_ds: Joint path derivative, shape ``(K, dof)`` [rad per unit s].
        velocity_limits: ``(dof,)`` [rad/s].

    Returns:
        ``(K,)``; ``inf`` where the joints do not move.
    """
    with np.errstate(divide="ignore"):
        ratio = np.where(np.abs(dq_ds) > 0, velocity_limits / np.abs(dq_ds), np.inf)
    return ratio.min(axis=1)
