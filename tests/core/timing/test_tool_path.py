"""The tool's speed along a joint path and its rate of change (``core.timing.tool_path``).

References: pinocchio's classical acceleration of the tool frame (``getFrameClassicalAcceleration``
after ``forwardKinematics`` with q, v, a), which is J a + (dJ/dt) v, for the shipped robots, a tool
offset and an inline URDF with a prismatic joint; and finite differences of |J q_s| along a path.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from core.timing.tool_path import jacobian_change, speed_rates
from robots import registry
from robots.model import Robot
from service.convert.robot import with_tool
from service.schemas.common import Tool

PRISMATIC = """<robot name="slider">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0.1"/><axis xyz="1 0 0"/><limit lower="0" upper="0.5" velocity="1" effort="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="tip"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
</robot>"""


def robots() -> list[Robot]:
    out = [registry.get(name) for name in ("ur5", "panda", "puma560", "planar_2r")]
    tool = Tool(position=[0.02, -0.03, 0.15], orientation=[0.0, 0.0, 0.0, 1.0])
    out.append(with_tool(registry.get("ur5"), tool))
    out.append(registry.resolve({"urdf": PRISMATIC, "tip_frame": "tip", "base_frame": "base"}))
    return out


def classical(robot: Robot, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Linear and angular acceleration (6,) of the robot's tool point, by pinocchio, in the base
    frame: J a + (dJ/dt) v."""
    J = robot.jacobian(q)
    # dJ/dt v by pinocchio: the classical acceleration at a = 0, through the tool's Jacobian
    # columns' own derivative (central differences of J along v would not be exact)
    model = robot.model
    data = model.createData()
    frame = model.getFrameId(robot.tip_frame)
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    acc = pin.getFrameClassicalAcceleration(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
    drift = np.concatenate([acc.linear, acc.angular])
    tip = data.oMf[frame]
    offset = robot.fk(q)[:3, 3] - tip.translation  # the tool's offset from the tip frame
    w = J[3:] @ v
    # a point fixed on the tip: a_p = a_tip + alpha x r + w x (w x r) (alpha x r is in J a)
    drift[:3] += np.cross(acc.angular, offset) + np.cross(w, np.cross(w, offset))
    return J @ a + drift


@pytest.mark.parametrize("robot", robots(), ids=lambda r: r.name)
def test_jacobian_change_is_pinocchios_classical_acceleration(robot: Robot) -> None:
    rng = np.random.default_rng(3)
    lo, hi = np.asarray(robot.position_limits, dtype=float).T
    for _ in range(5):
        q = rng.uniform(np.maximum(lo, -3.0), np.minimum(hi, 3.0))
        v, a = rng.normal(size=robot.dof), rng.normal(size=robot.dof)
        J = robot.jacobian(q)
        ours = J @ a + jacobian_change(J[None], v[None])[0]
        np.testing.assert_allclose(ours, classical(robot, q, v, a), atol=1e-12)


@pytest.mark.parametrize("robot", robots()[:2], ids=lambda r: r.name)
def test_speed_rate_is_the_derivative_of_the_tool_speed_along_a_path(robot: Robot) -> None:
    """rho_s = d|J q_s|/ds along q(s) = q0 + s d + s^2 e (central differences, h = 1e-6)."""
    rng = np.random.default_rng(5)
    q0 = np.asarray(robot.home, dtype=float)
    d, e = rng.normal(size=robot.dof), 0.3 * rng.normal(size=robot.dof)
    s = np.linspace(0.0, 0.5, 7)
    h = 1e-6

    def rho(x: np.ndarray) -> np.ndarray:
        q = q0 + x[:, None] * d + (x**2)[:, None] * e
        dq = d + 2.0 * x[:, None] * e
        return speed_rates(robot.jacobian_many(q), dq, np.tile(2.0 * e, (len(x), 1)))[0]

    q = q0 + s[:, None] * d + (s**2)[:, None] * e
    dq, ddq = d + 2.0 * s[:, None] * e, np.tile(2.0 * e, (len(s), 1))
    _, rho_s = speed_rates(robot.jacobian_many(q), dq, ddq)
    fd = (rho(s + h) - rho(s - h)) / (2.0 * h)
    np.testing.assert_allclose(rho_s, fd, rtol=1e-6, atol=1e-7)
