"""Analytic inverse kinematics of 6R arms (and the 6R sub-chain of a 7R arm with one joint held).

EAIK (pip ``EAIK``, subproblem decomposition of the joint axes, Ostermeier et al. 2024) solves every
6R arm whose axes it can decompose: three parallel axes (UR family), a spherical wrist (PUMA 560),
and more. It is given the chain in product-of-exponentials form, built here from the robot's own
model at q = 0 (so the base offset of the URDF and the tool frame's fixed offset from the last joint
are part of the geometry EAIK sees, not left out):

- ``H[k]``: joint k's unit axis in the base frame;
- ``P[0]``: base origin -> joint 1's origin, ``P[k]``: joint k's origin -> joint k+1's origin,
  ``P[6]``: joint 6's origin -> the tip frame's origin (base frame, meters);
- ``R6T``: the tip frame's orientation in the base frame at q = 0.

With a tool offset (a TCP, ``with_tool``) EAIK keeps the flange chain it was built for: a tool pose
is turned into the flange pose it needs (``T_base_tool @ inv(T_tip_tool)``) before EAIK solves it,
so the decomposition never sees the offset.

Its answers are candidates only: ``robots.ik`` keeps those whose pinocchio-consistent forward
kinematics (``Chain.fk_many``, tested equal to pinocchio) reproduces the pose to 1e-9 m and 1e-9 rad,
after a few Newton steps on the ones just outside (EAIK's least-squares branches near singularities).
Checked in tests: for UR5 and PUMA poses, every original q is among EAIK's answers and all verified
answers reproduce the pose (worst 7e-13 m over 2,000 random UR5 poses).
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

import eaik.pybindings.EAIK as _eaik
import numpy as np

from robots.chain import Chain


def zero_geometry(chain: Chain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(H (n, 3), P (n + 1, 3), T_tip (4, 4))``: the chain at q = 0 in product-of-exponentials
    form, in the base frame."""
    axes, origins, T = chain.joint_axes_many(np.zeros((1, len(chain.q_index))))
    o = origins[0]
    P = np.vstack([o[:1], np.diff(o, axis=0), T[0, :3, 3] - o[-1]])
    return axes[0], P, T[0]


@dataclass(frozen=True)
class AnalyticIK:
    """EAIK of one chain. ``held`` is the index of the joint held at a given value (7R arms), else None.

    Attributes:
        family: EAIK's name of the kinematic family, e.g. ``"6R-THREE_INNER_PARALLEL"``.
        held: Joint index held fixed (the redundant joint of a 7R arm), or None for a 6R arm.
        T_tool_tip: ``(4, 4)`` the flange (tip) in the tool frame, ``inv(T_tip_tool)``, or None
            without a tool offset.
    """

    family: str
    held: int | None
    H: np.ndarray = field(repr=False)
    P: np.ndarray = field(repr=False)
    R_tip: np.ndarray = field(repr=False)
    _solver: _eaik.Robot = field(repr=False, compare=False)
    _held_cache: OrderedDict[float, _eaik.Robot] = field(
        default_factory=OrderedDict, repr=False, compare=False
    )
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)
    T_tool_tip: np.ndarray | None = field(default=None, repr=False, compare=False)

    def with_tool(self, T_tip_tool: np.ndarray) -> AnalyticIK:
        """The same solver (EAIK objects and cache shared) answering for the tool frame
        ``T_tip_tool`` (4, 4) on the flange."""
        return dataclasses.replace(self, T_tool_tip=np.linalg.inv(T_tip_tool))

    def _flange(self, T_base_tool: np.ndarray) -> np.ndarray:
        """The flange pose(s) that put the tool at ``T_base_tool`` (4, 4) or (N, 4, 4)."""
        T = np.asarray(T_base_tool, dtype=float)
        return T if self.T_tool_tip is None else T @ self.T_tool_tip

    def _for(self, held_value: float | None) -> _eaik.Robot:
        if self.held is None:
            return self._solver
        key = float(held_value)  # type: ignore[arg-type]
        with self._lock:
            robot = self._held_cache.get(key)
            if robot is not None:
                self._held_cache.move_to_end(key)
                return robot
        robot = _eaik.Robot(self.H.T, self.P.T, self.R_tip, [(self.held, key)], True)
        if not robot.has_known_decomposition():  # a special held value: robots.ik goes numeric
            raise RuntimeError("EAIK knows no decomposition at this held value")
        with self._lock:
            self._held_cache[key] = robot
            while len(self._held_cache) > 64:
                self._held_cache.popitem(last=False)
        return robot

    def solve(self, T_base_tool: np.ndarray, held_value: float | None = None) -> np.ndarray:
        """Candidate joint positions ``(k, n)`` [rad] for the tool pose (unverified, each angle in
        (-pi, pi]); with a held joint, its column is ``held_value``."""
        solution = self._for(held_value).calculate_IK(
            np.ascontiguousarray(self._flange(T_base_tool))
        )
        Q = np.array(solution.Q, dtype=float).reshape(-1, len(self.H))
        if self.held is not None:
            Q[:, self.held] = held_value  # EAIK returns the held joint's column too
        return Q

    def solve_many(self, Ts: np.ndarray, threads: int = 1) -> list[np.ndarray]:
        """``solve`` for each pose of ``Ts`` ``(N, 4, 4)`` (6R arms only), in EAIK's batched C++ loop."""
        if self.held is not None:
            return [self.solve(T) for T in Ts]
        flanges = self._flange(Ts)
        out = self._solver.calculate_IK_batched([np.ascontiguousarray(T) for T in flanges], threads)
        n = len(self.H)
        return [np.asarray(s.Q, dtype=float).reshape(-1, n) for s in out]


HELD_PROBES = (0.7, -1.9, 2.6)
"""[rad]: held values at which a 7R arm's held joint must leave a chain EAIK decomposes, besides 0.
At q = 0 a URDF's axes often line up (a KUKA LBR iiwa's joints 5 and 7): holding joint 6 at 0
decomposes ("spherical, second two intersecting") but at any other value it does not, and EAIK then
missed solutions of poses it was asked to solve (robotics-toolbox's lbr_iiwa_14_r820)."""


def _decomposes(H: np.ndarray, P: np.ndarray, R: np.ndarray, held: int, value: float) -> bool:
    try:
        return bool(_eaik.Robot(H.T, P.T, R, [(held, value)], True).has_known_decomposition())
    except (RuntimeError, ValueError):
        return False


def build(chain: Chain, held_candidates: tuple[int, ...] = ()) -> AnalyticIK | None:
    """EAIK for an all-revolute chain of 6 joints, or of 7 with one of ``held_candidates`` held (the
    first one EAIK decomposes at 0 and at every ``HELD_PROBES`` value); None when EAIK knows no
    decomposition."""
    n = len(chain.q_index)
    if not chain.revolute.all() or n not in (6, 7):
        return None
    H, P, T = zero_geometry(chain)
    options: tuple[int | None, ...] = (None,) if n == 6 else held_candidates
    for held in options:
        fixed = [] if held is None else [(held, 0.0)]
        try:
            solver = _eaik.Robot(H.T, P.T, T[:3, :3], fixed, True)
        except (RuntimeError, ValueError):
            continue
        if not solver.has_known_decomposition():
            continue
        if held is not None and not all(_decomposes(H, P, T[:3, :3], held, v) for v in HELD_PROBES):
            continue
        return AnalyticIK(solver.get_kinematic_family(), held, H, P, T[:3, :3], solver)
    return None
