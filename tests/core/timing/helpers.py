"""Shared test inputs of the path timing tests: random joint walks and a toy ``Dynamics``."""

from __future__ import annotations

import numpy as np


def walk(seed: int, n: int, dof: int = 6, step: float = 0.3) -> np.ndarray:
    """``n`` waypoints of a seeded random walk, steps uniform in [-step, step] per joint."""
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.uniform(-step, step, (n, dof)), axis=0)


class Pendulums:
    """Independent joints: tau_j = I_j q''_j + k_j sin(q_j) (g / 9.81): a toy ``Dynamics``."""

    inertia = np.array([2.0, 1.0, 0.5])
    weight = np.array([3.0, 1.0, 0.2])

    def inverse_dynamics(self, q, qd, qdd, gravity):  # type: ignore[no-untyped-def]
        return self.inertia * qdd + self.weight * np.sin(q) * (-gravity[2] / 9.81)

    def path_coefficients(self, q, dq, ddq, gravity):  # type: ignore[no-untyped-def]
        return self.inertia * dq, self.inertia * ddq, self.weight * np.sin(q) * (-gravity[2] / 9.81)
