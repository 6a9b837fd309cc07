"""A toy planar 2R arm satisfying core.kinematics.Kinematics, independent of pinocchio.

Link lengths 1.0 m and 0.8 m, joints about z; closed-form FK, Jacobian and IK. Core tests use it so
the planning math is tested without the robots package.
"""

from __future__ import annotations

import math

import numpy as np

from core.derived_kinematics import DerivedKinematics
from core.kinematics import IKResult, SolutionSet


class ToyPlanar2R(DerivedKinematics):
    name = "toy_planar_2r"
    joint_names = ("shoulder", "elbow")
    dof = 2
    task_space = "position_xy"
    l1, l2 = 1.0, 0.8

    def __init__(self) -> None:
        self.position_limits = np.array([[-np.pi, np.pi], [-np.pi, np.pi]])
        self.velocity_limits = np.array([2.0, 2.0])
        self.acceleration_limits = np.array([10.0, 10.0])

    def fk_many(self, qs: np.ndarray) -> np.ndarray:
        qs = np.atleast_2d(qs)
        a, ab = qs[:, 0], qs[:, 0] + qs[:, 1]
        T = np.zeros((len(qs), 4, 4))
        T[:, 0, 0], T[:, 0, 1] = np.cos(ab), -np.sin(ab)
        T[:, 1, 0], T[:, 1, 1] = np.sin(ab), np.cos(ab)
        T[:, 2, 2] = T[:, 3, 3] = 1.0
        T[:, 0, 3] = self.l1 * np.cos(a) + self.l2 * np.cos(ab)
        T[:, 1, 3] = self.l1 * np.sin(a) + self.l2 * np.sin(ab)
        return T

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.fk_many(np.asarray(q)[None])[0]

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        a, ab = q[0], q[0] + q[1]
        J = np.zeros((6, 2))
        J[0] = [-self.l1 * np.sin(a) - self.l2 * np.sin(ab), -self.l2 * np.sin(ab)]
        J[1] = [self.l1 * np.cos(a) + self.l2 * np.cos(ab), self.l2 * np.cos(ab)]
        J[5] = [1.0, 1.0]
        return J

    def ik(
        self,
        T_base_tool,
        seed,
        *,
        max_iterations=100,
        position_tolerance=1e-6,
        orientation_tolerance=1e-6,
        respect_limits=True,
    ) -> IKResult:
        x, y = T_base_tool[0, 3], T_base_tool[1, 3]
        c2 = (x * x + y * y - self.l1**2 - self.l2**2) / (2 * self.l1 * self.l2)
        best = None
        for sign in (1.0, -1.0):
            q2 = sign * np.arccos(np.clip(c2, -1.0, 1.0))
            q1 = np.arctan2(y, x) - np.arctan2(self.l2 * np.sin(q2), self.l1 + self.l2 * np.cos(q2))
            q = np.array([q1, q2])
            q[0] = seed[0] + (q[0] - seed[0] + np.pi) % (2 * np.pi) - np.pi
            if best is None or np.linalg.norm(q - seed) < np.linalg.norm(best - seed):
                best = q
        err = float(np.linalg.norm(self.fk(best)[:2, 3] - [x, y]))
        lo, hi = self.position_limits.T
        inside = bool(np.all(best >= lo) and np.all(best <= hi))
        ok = err <= position_tolerance and inside
        return IKResult(best, ok, err, 0.0, 1, inside)


class FlippingToy(ToyPlanar2R):
    """The toy arm whose IK answers the other elbow branch past x = 1.1 m (a branch flip)."""

    def ik(self, T_base_tool, seed, **kw) -> IKResult:
        r = super().ik(T_base_tool, seed, **kw)
        if T_base_tool[0, 3] <= 1.1:
            return r
        q1, q2 = r.positions
        other = np.array([q1 + 2 * math.atan2(0.8 * math.sin(q2), 1.0 + 0.8 * math.cos(q2)), -q2])
        return r._replace(positions=other)


class LabelledToy(ToyPlanar2R):
    """The toy arm with configuration labels (``down``: q2 >= 0, ``up``: q2 < 0, as the shipped
    planar arm's) and every IK solution (the closed form's two elbows); past x = ``x_cut`` [m] the
    ``down`` solutions do not exist (a pose there has only ``up``), so a line from a ``down`` start
    must flip its branch where it crosses x_cut."""

    x_cut = 1.1

    def configuration(self, q):
        return "down" if q[1] >= 0.0 else "up"

    def configurations(self, qs):
        return ["down" if q2 >= 0.0 else "up" for q2 in np.atleast_2d(qs)[:, 1]]

    def ik_all(self, T_base_tool, seed=None):
        x, y = T_base_tool[0, 3], T_base_tool[1, 3]
        c2 = (x * x + y * y - self.l1**2 - self.l2**2) / (2 * self.l1 * self.l2)
        if abs(c2) > 1.0:
            return SolutionSet(np.zeros((0, 2)), (), 0)
        sols = []
        for sign in (1.0, -1.0):
            q2 = sign * math.acos(c2)
            q1 = math.atan2(y, x) - math.atan2(
                self.l2 * math.sin(q2), self.l1 + self.l2 * math.cos(q2)
            )
            if sign > 0 and x > self.x_cut:
                continue
            sols.append([q1, q2])
        Q = np.array(sols)
        return SolutionSet(Q, tuple(self.configurations(Q)), 0)

    def ik(self, T_base_tool, seed, **kw) -> IKResult:
        r = super().ik(T_base_tool, seed, **kw)
        if T_base_tool[0, 3] > self.x_cut and r.positions[1] >= 0.0:
            return r._replace(positions=self.ik_all(T_base_tool).positions[0])
        return r
