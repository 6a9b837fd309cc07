"""Rigid-body dynamics of the shipped robots against independent computations.

- The Robotics Toolbox's ``rne`` (its own Newton-Euler on DH frames) on DH models built here from the
  cited parameters (Corke's Puma560 as shipped in the toolbox; UR's page and UR's ROS 2 description
  for the UR5; Gaz et al. via franka_description for the Panda): the URDFs' ``<inertial>`` tags
  encode the same bodies in their own link frames.
- pinocchio's CRBA (the mass matrix) for the path coefficient a = M q_s, and the path form itself:
  a s'' + b s'^2 + c equals the inverse dynamics of the motion with q' = q_s s', q'' = q_s s'' +
  q_ss s'^2.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from core.errors import InvalidURDF
from robots import registry
from robots.dynamics import BATCH, screened_inertial

rtb = pytest.importorskip("roboticstoolbox")
G = np.array([0.0, 0.0, -9.81])
PI = np.pi


def ur5_model():  # type: ignore[no-untyped-def]
    a = [0, -0.425, -0.39225, 0, 0, 0]
    d = [0.089159, 0, 0, 0.10915, 0.09465, 0.0823]
    alpha = [PI / 2, 0, 0, PI / 2, -PI / 2, 0]
    mass = [3.7, 8.393, 2.33, 1.219, 1.219, 0.1879]
    com = [
        [0, -0.02561, 0.00193], [0.2125, 0, 0.11336], [0.15, 0, 0.0265],
        [0, -0.0018, 0.01634], [0, 0.0018, 0.01634], [0, 0, -0.001159],
    ]  # fmt: skip
    # UR's ROS 2 description: cylinders (I about the axis, I across it), axis in the DH frame
    cyl = [
        (0.01040625, 0.014972358333333331, 1), (0.0151074, 0.13388583541666665, 0),
        (0.004095, 0.031216803515624995, 0), (0.0021942, 0.002013889583333333, 1),
        (0.0021942, 0.0018310395833333333, 1), (0.0001321171875, 8.062475833333332e-05, 2),
    ]  # fmt: skip
    links = []
    for i in range(6):
        axial, across, k = cyl[i]
        diag = [across] * 3
        diag[k] = axial
        links.append(
            rtb.RevoluteDH(d=d[i], a=a[i], alpha=alpha[i], m=mass[i], r=com[i], I=[*diag, 0, 0, 0])
        )
    return rtb.DHRobot(links)


def panda_model():  # type: ignore[no-untyped-def]
    # franka_description inertial.yaml (Gaz et al. 2019): com, mass, ixx ixy ixz iyy iyz izz
    p = [
        ((0.003875, 0.002081, -0.04762), 4.970684, (0.70337, -0.000139, 0.006772, 0.70661, 0.019169, 0.009117)),
        ((-0.003141, -0.02872, 0.003495), 0.646926, (0.007962, -3.925e-3, 1.0254e-2, 2.811e-2, 7.04e-4, 2.5995e-2)),
        ((2.7518e-2, 3.9252e-2, -6.6502e-2), 3.228604, (3.7242e-2, -4.761e-3, -1.1396e-2, 3.6155e-2, -1.2805e-2, 1.083e-2)),
        ((-5.317e-2, 1.04419e-1, 2.7454e-2), 3.587895, (2.5853e-2, 7.796e-3, -1.332e-3, 1.9552e-2, 8.641e-3, 2.8323e-2)),
        ((-1.1953e-2, 4.1065e-2, -3.8437e-2), 1.225946, (3.5549e-2, -2.117e-3, -4.037e-3, 2.9474e-2, 2.29e-4, 8.627e-3)),
        ((6.0149e-2, -1.4117e-2, -1.0517e-2), 1.666555, (1.964e-3, 1.09e-4, -1.158e-3, 4.354e-3, 3.41e-4, 5.433e-3)),
        ((1.0517e-2, -4.252e-3, 6.1597e-2), 7.35522e-1, (1.2516e-2, -4.28e-4, -1.196e-3, 1.0027e-2, -7.41e-4, 4.815e-3)),
    ]  # fmt: skip
    a = [0, 0, 0, 0.0825, -0.0825, 0, 0.088]
    d = [0.333, 0, 0.316, 0, 0.384, 0, 0]
    alpha = [0, -PI / 2, PI / 2, PI / 2, -PI / 2, PI / 2, PI / 2]
    links = []
    for i, (com, mass, (xx, xy, xz, yy, yz, zz)) in enumerate(p):
        links.append(
            rtb.RevoluteMDH(
                a=a[i], d=d[i], alpha=alpha[i], m=mass, r=com, I=[xx, yy, zz, xy, yz, xz]
            )
        )
    return rtb.DHRobot(links)


REFERENCES = {
    "puma560": lambda: rtb.models.DH.Puma560().nofriction(coulomb=True, viscous=True),
    "ur5": ur5_model,
    "panda": panda_model,
}


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_inverse_dynamics_against_the_robotics_toolbox(name: str) -> None:
    robot = registry.get(name)
    reference = REFERENCES[name]()
    rng = np.random.default_rng(1)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    n = BATCH + 2  # the batched RNEA path; the loop is checked below
    q = rng.uniform(np.maximum(lo, -3), np.minimum(hi, 3), (n, robot.dof))
    qd, qdd = rng.uniform(-2, 2, (2, n, robot.dof))
    ours = robot.dynamics.inverse_dynamics(q, qd, qdd, G)
    want = np.array([reference.rne(q[i], qd[i], qdd[i], gravity=G) for i in range(n)])
    np.testing.assert_allclose(ours, want, atol=1e-9 * np.abs(want).max())
    few = robot.dynamics.inverse_dynamics(q[:3], qd[:3], qdd[:3], G)
    np.testing.assert_allclose(few, want[:3], atol=1e-9 * np.abs(want).max())


@pytest.mark.parametrize("name", ["panda", "ur5", "puma560", "planar_2r"])
def test_path_coefficients(name: str) -> None:
    robot = registry.get(name)
    rng = np.random.default_rng(2)
    n = 5
    q, dq, ddq = rng.uniform(-1, 1, (3, n, robot.dof))
    a, b, c = robot.dynamics.path_coefficients(q, dq, ddq, G)
    model = pin.Model(robot.model)
    data = model.createData()
    for i in range(n):
        M = pin.crba(model, data, q[i])
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(a[i], M @ dq[i], atol=1e-10)
    for sd, sdd in ((0.7, -1.3), (2.0, 0.5)):
        tau = robot.dynamics.inverse_dynamics(q, dq * sd, dq * sdd + ddq * sd**2, G)
        np.testing.assert_allclose(a * sdd + b * sd**2 + c, tau, atol=1e-10)
    # gravity in the base frame: the planar arm moves in the horizontal plane, none acts on it
    if name == "planar_2r":
        np.testing.assert_allclose(c, 0.0, atol=1e-12)


def test_shipped_robots_have_dynamics_and_maker_effort_limits() -> None:
    expected = {
        "panda": [87.0] * 4 + [12.0] * 3,
        "ur5": [150.0] * 3 + [28.0] * 3,
        "puma560": None,
        "planar_2r": None,
    }
    for name, effort in expected.items():
        robot = registry.get(name)
        assert robot.dynamics is not None
        if effort is None:
            assert robot.effort_limits is None
        else:
            np.testing.assert_array_equal(robot.effort_limits, effort)


INLINE = """<robot name="two">
  <link name="base"/>
  <link name="l1">{inertial}</link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="2" effort="{effort}"/></joint>
  <link name="l2"><inertial><mass value="1"/><origin xyz="0.5 0 0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="2" effort="7"/></joint>
  <link name="tool0"/>
  <joint name="tip" type="fixed"><parent link="l2"/><child link="tool0"/></joint>
</robot>"""
INERTIAL = (
    '<inertial><mass value="{m}"/><origin xyz="0.5 0 0"/>'
    '<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>'
)


def test_inline_dynamics_need_an_inertial_on_every_moving_link() -> None:
    with_all = registry.load_inline(
        INLINE.format(inertial=INERTIAL.format(m=2, ixx=0.01), effort=5)
    )
    assert with_all.dynamics is not None
    np.testing.assert_array_equal(with_all.effort_limits, [5.0, 7.0])
    # a point mass at 0.5 m on joint 2's arm: pinocchio's gravity torque at q = 0 is m g r
    tau = with_all.dynamics.inverse_dynamics(
        np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), G
    )
    assert tau[0, 1] == pytest.approx(-1.0 * 9.81 * 0.5, rel=1e-12)
    missing = registry.load_inline(INLINE.format(inertial="", effort=0))
    assert missing.dynamics is None and missing.effort_limits is None


@pytest.mark.parametrize(
    "inertial",
    [
        INERTIAL.format(m=-1, ixx=0.01),
        INERTIAL.format(m=1, ixx=-0.5),
        INERTIAL.format(m="nan", ixx=0.01),
        INERTIAL.format(m=1e9, ixx=0.01),
        '<inertial><mass value="1"/><origin xyz="0 1"/></inertial>',
    ],
)
def test_bad_inertials_are_invalid_urdf(inertial: str) -> None:
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(INLINE.format(inertial=inertial, effort=5))
    assert "inertial" in err.value.detail


def test_screened_inertial_keeps_the_numbers() -> None:
    import xml.etree.ElementTree as ET

    element = ET.fromstring(INERTIAL.format(m=2.5, ixx=0.01))
    out = screened_inertial(element, "l1")
    assert out is not None and out.find("mass").get("value") == "2.5"  # type: ignore[union-attr]
    assert screened_inertial(None, "l1") is None
