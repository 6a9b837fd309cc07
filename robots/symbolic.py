"""Forward kinematics as a CasADi expression, built from the pinocchio model.

The ``pin`` wheel has no ``pinocchio.casadi``, so the expression is built by walking the same joint
chain as ``Robot.fk_many`` (``robots.chain.Chain``: joint placements from ``model.jointPlacements``,
joint axes and types from each joint's motion subspace, the tip frame's placement). Used by the
bounded-deviation NLP (``core/cartesian/knot_nlp.py``, through ``Robot.fk_casadi``), where IPOPT needs exact derivatives of FK.
"""

from __future__ import annotations

import weakref
from typing import Protocol

import casadi as ca
import numpy as np

from robots.chain import Chain


class HasChain(Protocol):
    """What ``fk_casadi`` reads of a robot (``robots.model.Robot`` has both)."""

    @property
    def dof(self) -> int: ...

    @property
    def chain(self) -> Chain: ...


_cache: weakref.WeakKeyDictionary[object, ca.Function] = weakref.WeakKeyDictionary()


def _rotation(axis: np.ndarray, angle: ca.SX) -> ca.SX:
    """Rodrigues: rotation by ``angle`` [rad] about the unit ``axis`` (3,)."""
    K = ca.DM([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return ca.DM.eye(3) + ca.sin(angle) * K + (1.0 - ca.cos(angle)) * (K @ K)


def chain_fk(chain: Chain, q: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Symbolic tip position (3,) [m] and rotation (3, 3) in the base frame for joint symbols ``q``."""
    R: ca.SX = ca.SX(ca.DM(chain.T_base_world[:3, :3]))
    p: ca.SX = ca.SX(ca.DM(chain.T_base_world[:3, 3]))
    for k in range(len(chain.q_index)):
        x = q[int(chain.q_index[k])]
        p = p + R @ ca.DM(chain.translations[k])
        R = R @ ca.DM(chain.rotations[k])
        if chain.revolute[k]:
            R = R @ _rotation(chain.axes[k], x)
        else:
            p = p + (R @ ca.DM(chain.axes[k])) * x
    p = p + R @ ca.DM(chain.T_last_tip[:3, 3])
    R = R @ ca.DM(chain.T_last_tip[:3, :3])
    return p, R


def fk_casadi(robot: HasChain) -> ca.Function:
    """``casadi.Function`` ``fk(q) -> (p, R)``: q (dof,) [rad or m] to the tip position p (3,) [m]
    and rotation R (3, 3) in the base frame. Built once per robot (SX graph, cached weakly).

    ``robot`` must expose ``chain`` (a ``robots.model.Robot`` does).
    """
    cached = _cache.get(robot)
    if cached is not None:
        return cached
    chain = robot.chain
    q = ca.SX.sym("q", robot.dof)
    p, R = chain_fk(chain, q)
    fn = ca.Function("fk", [q], [p, R], ["q"], ["p", "R"])
    _cache[robot] = fn
    return fn
