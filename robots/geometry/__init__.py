"""Collision shapes fixed to links: the shipped robots' capsules, and boxes and cylinders (inline URDFs).

A capsule is the set of points within ``radius`` of the segment ``a``-``b`` (link frame, meters); a
sphere is a capsule with ``a == b``. Capsules give exact, cheap distances (segment-segment) and cover
the arm conservatively. An inline URDF's ``<collision>`` boxes and cylinders stay boxes and cylinders
(``Box``, ``Cylinder``; ``robots.geometry.urdf``). Every shipped robot's entry names its sources
(``ROBOT_GEOMETRY[name].sources``); docs/robots.md "Collision geometry" repeats them.

Frames: the shipped URDFs use DH frames (UR5, PUMA 560: standard DH; Panda: modified DH, identical to
franka_description's ``panda_linkN`` frames), so offsets that the DH model folds into ``d`` (UR5's
shoulder and elbow offsets along the joint axes) are written out here where the real arm's tubes run.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Capsule:
    """A capsule fixed to ``link``: segment ``a``-``b`` in the link frame [m], ``radius`` [m] > 0."""

    link: str
    a: tuple[float, float, float]
    b: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class Box:
    """A box fixed to ``link``: full edge lengths ``size`` [m] along the axes of ``T_link_shape``
    (4, 4), its centre and orientation in the link frame."""

    link: str
    size: tuple[float, float, float]
    T_link_shape: np.ndarray = field(default_factory=lambda: np.eye(4), compare=False)


@dataclass(frozen=True)
class Cylinder:
    """A cylinder fixed to ``link``: ``radius`` [m], ``length`` [m] along the z axis of
    ``T_link_shape`` (4, 4), centred on its origin (in the link frame)."""

    link: str
    radius: float
    length: float
    T_link_shape: np.ndarray = field(default_factory=lambda: np.eye(4), compare=False)


LinkShape = Capsule | Box | Cylinder
"""One collision shape fixed to a link."""


@dataclass(frozen=True)
class RobotGeometry:
    """Collision capsules of one robot and where their dimensions come from."""

    capsules: tuple[Capsule, ...]
    sources: tuple[str, ...]


def _z(link: str, z0: float, z1: float, r: float, x: float = 0.0, y: float = 0.0) -> Capsule:
    """Capsule along the link's z axis from z0 to z1 [m] through (x, y)."""
    return Capsule(link, (x, y, z0), (x, y, z1), r)


# Franka Emika Panda: Franka's own self-collision capsule model (franka_ros, franka_description
# robots/common/franka_arm.xacro, the ``*_sc`` links; utils.xacro ``collision_capsule``: ``length`` is
# the distance between the sphere centres, ``xyz`` the centre, ``direction`` the axis; link7's ``_sc``
# frame is rotated by pi/4 about z). Radii with safety_distance = 0.
_S = 0.5**0.5  # cos(pi/4) = sin(pi/4): link7's capsule frame is Rz(pi/4) of panda_link7
PANDA = RobotGeometry(
    capsules=(
        Capsule("panda_link0", (-0.09, 0.0, 0.06), (-0.06, 0.0, 0.06), 0.06),
        _z("panda_link1", -0.1915 - 0.1415, -0.1915 + 0.1415, 0.06),
        _z("panda_link2", -0.06, 0.06, 0.06),
        _z("panda_link3", -0.145 - 0.075, -0.145 + 0.075, 0.06),
        _z("panda_link4", -0.06, 0.06, 0.06),
        _z("panda_link5", -0.26 - 0.05, -0.26 + 0.05, 0.06),
        _z("panda_link5", -0.13 - 0.07, -0.13 + 0.07, 0.025, y=0.08),
        _z("panda_link6", -0.03 - 0.04, -0.03 + 0.04, 0.05),
        _z("panda_link7", 0.01 - 0.07, 0.01 + 0.07, 0.04),
        Capsule(
            "panda_link7", (0.055 * _S, 0.055 * _S, 0.082), (0.065 * _S, 0.065 * _S, 0.082), 0.03
        ),
    ),
    sources=(
        "Franka Emika, franka_ros franka_description/robots/common/franka_arm.xacro: the arm's "
        "self-collision capsules (*_sc links), safety_distance 0",
    ),
)

# Universal Robots UR5 (CB3). Radii: the UR5 technical drawing (base footprint diameter 149 mm, tool
# flange diameter 63 mm), shoulder and elbow housings about 120 mm across; NVIDIA cuRobo's UR5 sphere
# model (content/configs/robot/ur5.yml: shoulder sphere radius 0.06 m). Offsets along the joint axes:
# ur_description's UR5 kinematics (shoulder offset 0.13585 m, elbow offset -0.1197 m, wrist 0.093 m),
# whose sum is the DH d4 = 0.10915 m; in the DH frames the upper arm tube runs at z = 0.13585 m of
# upper_arm_link and the forearm tube at z = 0.01615 m of forearm_link.
UR5 = RobotGeometry(
    capsules=(
        _z("base_link", 0.0, 0.04, 0.075),
        _z("shoulder_link", -0.02, 0.02, 0.06),
        _z("upper_arm_link", 0.0, 0.13585, 0.06),
        Capsule("upper_arm_link", (0.0, 0.0, 0.13585), (-0.425, 0.0, 0.13585), 0.06),
        Capsule("forearm_link", (0.0, 0.0, 0.01615), (-0.39225, 0.0, 0.01615), 0.05),
        _z("wrist_1_link", -0.093, 0.0, 0.045),
        _z("wrist_2_link", -0.09465, 0.0, 0.045),
        _z("wrist_3_link", -0.0823, -0.01, 0.0375),
    ),
    sources=(
        "Universal Robots, UR5 technical specifications and drawing: base diameter 149 mm, "
        "tool flange diameter 63 mm",
        "ros-industrial universal_robot ur_description ur5: shoulder offset 0.13585 m, elbow "
        "offset 0.1197 m, wrist 1 offset 0.093 m (where the tubes run)",
        "NVIDIA cuRobo UR5 collision spheres (content/configs/robot/ur5.yml): shoulder radius 0.06 m",
    ),
)

# Unimation PUMA 560 in Corke's DH frames (base_link on the floor, shoulder at d1 = 0.6718 m). No
# published capsule model was found: the radii are estimates from the arm's layout drawing in
# Unimation's PUMA Mark II 500 series equipment manual and the link lengths of Corke's model
# (a2 = 0.4318 m upper arm, d4 = 0.4318 m forearm, d3 = 0.15005 m shoulder offset). link4 is the
# wrist housing that rolls with joint 4: its frame sits at the wrist centre with z along the forearm
# (pointing away from the elbow), so the housing runs along -z up to the centre.
PUMA560 = RobotGeometry(
    capsules=(
        _z("base_link", 0.0, 0.5, 0.1),
        _z("link1", -0.12, 0.0, 0.12),
        _z("link2", 0.0, 0.15005, 0.1),
        Capsule("link2", (0.0, 0.0, 0.15005), (0.4318, 0.0, 0.15005), 0.09),
        Capsule("link3", (0.0203, -0.06, 0.0), (0.0203, 0.37, 0.0), 0.06),
        _z("link4", -0.08, 0.0, 0.05),
        Capsule("link5", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.055),
        _z("link6", 0.02, 0.06, 0.035),
    ),
    sources=(
        "Corke, Robotics Toolbox puma560 (link lengths a2, d3, d4: where the capsules run)",
        "radii: estimates from Unimation's PUMA 560 arm layout drawing (no published capsule "
        "model found); conservative",
        "link4 (the wrist housing rolling with joint 4): 8 cm along the forearm axis up to the "
        "wrist centre, radius 5 cm, from the same drawing",
    ),
)

# The course notes' planar 2R arm (not a real robot): capsules along the two links, radius chosen.
PLANAR_2R = RobotGeometry(
    capsules=(
        Capsule("link1", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.05),
        Capsule("link2", (0.0, 0.0, 0.0), (0.8, 0.0, 0.0), 0.05),
    ),
    sources=("not a real robot: capsules along l1 = 1.0 m and l2 = 0.8 m, radius 0.05 m chosen",),
)

ROBOT_GEOMETRY: dict[str, RobotGeometry] = {
    "planar_2r": PLANAR_2R,
    "puma560": PUMA560,
    "ur5": UR5,
    "panda": PANDA,
}
"""Shipped robot name -> its collision capsules (link frames of the vendored URDF)."""
