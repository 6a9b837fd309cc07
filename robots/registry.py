"""Robot names -> frozen descriptions, and the one loader (shipped and client URDFs alike).

Shipped robots (``robots/urdf/``, written from published DH parameters; see each file's header):

========== ===== ============== ============ =================================================
name        dof  base_frame     tip_frame    limits: position and velocity in the URDF,
                                             acceleration here; sources in ``SOURCES``
========== ===== ============== ============ =================================================
planar_2r     2  base_link      tool0        course-notes arm (task space ``position_xy``)
puma560       6  base_link      tool0        Corke's PUMA 560 (standard DH)
ur5           6  base_link      tool0        Universal Robots UR5 (standard DH)
panda         7  panda_link0    panda_link8  Franka Emika Panda, flange (modified DH)
========== ===== ============== ============ =================================================

Client URDFs (``load_inline``) are screened by ``robots.urdf_screen``; the robot's joints are the
movable joints on the path from the root to ``tip_frame`` (every other joint is locked at 0 with
``pin.buildReducedModel``), so URDFs with fingers or branches work. ``base_frame`` defaults to the root
link and ``tip_frame`` to the end of the chain below it (``robots.urdf_screen.default_tip``: 422
``invalid_urdf`` naming the candidate leaves when the tree branches). Defaults for what a URDF leaves
out: velocity ``DEFAULT_VELOCITY`` (pi rad/s revolute, 1 m/s prismatic) where the URDF's is missing
or 0, acceleration ``DEFAULT_ACCELERATION`` (10 rad/s^2, 5 m/s^2), home = zeros clipped into the
limits, task space ``position_xy`` when every joint moves the tip in the base x-y plane (revolute
about base z, prismatic perpendicular to it), else ``pose``. Parsed client models are cached (LRU,
``TRAJ_URDF_CACHE_SIZE`` entries, default 32) by the sha256 of (urdf, tip_frame, base_frame) with the
frames resolved (the robot's name is ``inline-`` and that hash), and, when a frame was left out, also
under the frames as given (absent ones marked as such), so a repeated request skips the screening.
"""

from __future__ import annotations

import hashlib
import math
import os
import threading
import xml.etree.ElementTree as ET
from collections import OrderedDict
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import numpy as np
import pinocchio as pin

from core.errors import InputError, InvalidURDF, UnknownRobot
from robots import ik_numeric as _ik
from robots.dynamics import has_inertials
from robots.model import Robot
from robots.urdf_screen import ScreenedURDF, screen_urdf

PI = math.pi
DEFAULT_VELOCITY = {"revolute": PI, "prismatic": 1.0}
"""[rad/s], [m/s]: used where a client URDF's velocity limit is missing or 0."""
DEFAULT_ACCELERATION = {"revolute": 10.0, "prismatic": 5.0}
"""[rad/s^2], [m/s^2]: a URDF cannot state acceleration limits."""


@dataclass(frozen=True)
class RobotDescription:
    """What the registry knows of a shipped robot besides its URDF.

    Attributes:
        urdf: File name in ``robots/urdf/``.
        acceleration_limits: ``(dof,)`` [rad/s^2] (a URDF cannot hold them).
        home: ``(dof,)`` [rad], inside the limits and away from singularities.
        sources: Where the position, velocity and acceleration limits come from.
        link_lengths: For the planar arm's closed-form IK [m].
    """

    name: str
    urdf: str
    base_frame: str
    tip_frame: str
    task_space: str
    acceleration_limits: tuple[float, ...]
    home: tuple[float, ...]
    sources: dict[str, str] = field(hash=False)
    link_lengths: tuple[float, float] | None = None
    jerk_limits: tuple[float, ...] | None = None
    armature: tuple[float, ...] | None = None
    """Rotor inertia reflected through the gear, ``Jm G^2`` [kg m^2] per joint (dynamics)."""


DESCRIPTIONS: dict[str, RobotDescription] = {
    d.name: d
    for d in (
        RobotDescription(
            "planar_2r",
            "planar_2r.urdf",
            "base_link",
            "tool0",
            "position_xy",
            acceleration_limits=(10.0, 10.0),
            home=(0.0, PI / 2),
            sources={
                "position": "+-pi rad: issue 3 (the course notes' 2-link arm)",
                "velocity": "pi rad/s: not a real robot; the service's default for URDFs without rate limits",
                "acceleration": "10 rad/s^2: not a real robot; the service's default for URDFs",
                "home": "elbow at 90 deg, where manipulability l1 l2 |sin q2| is largest",
                "inertia": "not a real robot: uniform slender rods of 1 kg/m along each link "
                "(docs/robots.md)",
                "effort": "none: not a real robot",
            },
            link_lengths=(1.0, 0.8),
        ),
        RobotDescription(
            "puma560",
            "puma560.urdf",
            "base_link",
            "tool0",
            "pose",
            acceleration_limits=(2.0, 2.0, 2.0, 4.0, 4.0, 4.0),
            home=(0.0, PI / 4, -PI, 0.0, PI / 4, 0.0),
            sources={
                "position": "Corke's PUMA 560 model (Robotics Toolbox qlim), as given in issue 3",
                "velocity": "engineering choice, 1 rad/s (joints 1-3), 2 rad/s (wrist): Corke's model "
                "has no rate limits and no citable manufacturer joint-rate table was found",
                "acceleration": "engineering choice, 2 rad/s^2 (joints 1-3), 4 rad/s^2 (wrist): twice "
                "the velocity limit per second, conservative for the arm's era",
                "home": "Corke's nominal non-singular pose qn = [0, pi/4, pi, 0, pi/4, 0], with q3 "
                "written -pi (the same pose; +pi is outside joint 3's [-225, 45] deg)",
                "inertia": "Corke's Robotics Toolbox Puma560 (Armstrong, Khatib, Burdick 1986; "
                "Corke and Armstrong-Helouvry 1994): link masses, centres of mass, inertias and "
                "rotor inertia Jm G^2 (docs/robots.md)",
                "effort": "none: no manufacturer torque table was found",
            },
            armature=tuple(
                jm * g * g
                for jm, g in zip(
                    (200e-6, 200e-6, 200e-6, 33e-6, 33e-6, 33e-6),
                    (-62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686),
                    strict=True,
                )
            ),
        ),
        RobotDescription(
            "ur5",
            "ur5.urdf",
            "base_link",
            "tool0",
            "pose",
            acceleration_limits=(5.0,) * 6,
            home=(0.0, -PI / 3, PI / 2, -2 * PI / 3, -PI / 2, 0.0),
            sources={
                "position": "+-2 pi rad: UR5 datasheet (every joint +-360 deg)",
                "velocity": "pi rad/s (180 deg/s): UR5 datasheet",
                "acceleration": "5 rad/s^2: Universal Robots' ur_moveit_config joint_limits.yaml "
                "(UR publishes no joint acceleration limit; only torques bound it)",
                "home": "chosen: elbow bent 90 deg, wrist 2 at -90 deg (far from q5 = 0 and the "
                "shoulder singularity)",
                "inertia": "Universal Robots, 'DH parameters for calculations of kinematics and "
                "dynamics' (masses, centres of mass); inertia tensors from UR's "
                "Universal_Robots_ROS2_Description (cylinder approximation) (docs/robots.md)",
                "effort": "150 N m (joints 1-3), 28 N m (wrists): Universal Robots, 'Max. joint "
                "torques' (UR5 CB3)",
            },
        ),
        RobotDescription(
            "panda",
            "panda.urdf",
            "panda_link0",
            "panda_link8",
            "pose",
            acceleration_limits=(15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
            home=(0.0, -PI / 4, 0.0, -3 * PI / 4, 0.0, PI / 2, PI / 4),
            sources={
                "position": "Franka Emika datasheet (robot and interface specifications)",
                "velocity": "Franka Emika datasheet: 2.175 rad/s (joints 1-4), 2.61 rad/s (5-7)",
                "acceleration": "Franka Emika datasheet: 15, 7.5, 10, 12.5, 15, 20, 20 rad/s^2",
                "jerk": "Franka Control Interface documentation, 'Limits for Panda' "
                "(frankaemika.github.io/docs/control_parameters.html): 7500 rad/s^3 per joint",
                "home": "Franka's 'ready' pose",
                "inertia": "Gaz et al., 'Dynamic identification of the Franka Emika Panda robot "
                "with retrieval of feasible parameters using penalty-based optimization', RA-L "
                "2019, as in franka_ros franka_description inertial.yaml",
                "effort": "Franka Emika datasheet: 87 N m (joints 1-4), 12 N m (5-7)",
            },
            jerk_limits=(7500.0,) * 7,
        ),
    )
}


def names() -> list[str]:
    """Registered robot names, sorted."""
    return sorted(DESCRIPTIONS)


_shipped: dict[str, Robot] = {}
_shipped_lock = threading.Lock()


def get(name: str) -> Robot:
    """The registered robot ``name`` (built once); ``UnknownRobot`` lists the available names."""
    robot = _shipped.get(name)
    if robot is not None:
        return robot
    if name not in DESCRIPTIONS:
        raise UnknownRobot("no robot is registered under that name", extra={"available": names()})
    with _shipped_lock:  # build once even when the first requests arrive together
        if name not in _shipped:
            _shipped[name] = _build_shipped(name)
        return _shipped[name]


def _build_shipped(name: str) -> Robot:
    d = DESCRIPTIONS[name]
    urdf = resources.files("robots").joinpath("urdf", d.urdf).read_text(encoding="utf-8")
    model, _, screened = _reduced_model(urdf, d.tip_frame, d.base_frame)
    if d.armature is not None:
        model.armature = np.array(d.armature)
    closed_form = None
    if d.link_lengths is not None:
        l1, l2 = d.link_lengths
        lo, hi = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
        closed_form = lambda xy, seed: _ik.planar_2r(xy, seed, l1, l2, lo, hi)  # noqa: E731
    return Robot(
        name, model, base_frame=d.base_frame, tip_frame=d.tip_frame, task_space=d.task_space,
        acceleration_limits=np.array(d.acceleration_limits), home=np.array(d.home),
        closed_form_ik=closed_form, sources=d.sources,
        jerk_limits=None if d.jerk_limits is None else np.array(d.jerk_limits),
        with_dynamics=has_inertials(screened.xml, screened.chain),
    )  # fmt: skip


def _reduced_model(
    urdf: str, tip: str | None, base: str | None
) -> tuple[pin.Model, dict[str, str], ScreenedURDF]:
    """Screened URDF -> pinocchio model of the root-to-tip chain; returns it, the joint types and the
    screening's result (its frames resolved: ``None`` frames get their defaults)."""
    screened = screen_urdf(urdf, tip, base)
    try:
        model = pin.buildModelFromXML(_lock_off_chain(screened.xml, set(screened.chain)))
    except Exception as e:  # pinocchio raises plain RuntimeError/ValueError
        raise InvalidURDF(
            "the URDF could not be turned into a kinematic model", field=("robot", "urdf")
        ) from e
    return model, screened.joint_types, screened


def _lock_off_chain(xml: str, chain: set[str]) -> str:
    """The screened URDF with every movable joint off the root-to-tip chain turned ``fixed`` (at
    position 0, the neutral configuration of every screened joint type).

    Locking them in the URDF rather than with ``pin.buildReducedModel`` matters: pinocchio's reduction
    looks frames up by name without a frame type and fails ("Several frames match the filter") when
    a link and a joint share a name, as in the SO-ARM100 (link and joint ``gripper``).
    """
    root = ET.fromstring(xml)  # the screener's own output: already checked, no DTD, no entities
    for element in root.iter("joint"):
        if element.get("type") != "fixed" and element.get("name") not in chain:
            element.set("type", "fixed")
            for child in list(element):
                if child.tag in ("axis", "limit"):
                    element.remove(child)
    return ET.tostring(root, encoding="unicode")


_cache: OrderedDict[str, Robot] = OrderedDict()
_cache_lock = threading.Lock()


def cache_size() -> int:
    """Client models kept (``TRAJ_URDF_CACHE_SIZE``, default 32)."""
    try:
        return max(0, int(os.environ.get("TRAJ_URDF_CACHE_SIZE", "32")))
    except ValueError:
        return 32


def _key(urdf: str, tip_frame: str | None, base_frame: str | None) -> str:
    """The cache key of a client model: sha256 of the three texts joined by NUL (no URDF or link name
    that screening accepts holds a NUL), with a fourth part marking frames left out (``None``)."""
    parts: tuple[str, ...] = (urdf, tip_frame or "", base_frame or "")
    if tip_frame is None or base_frame is None:
        parts += ("default frames",)
    return hashlib.sha256("\0".join(parts).encode("utf-8")).hexdigest()


def _cached(key: str) -> Robot | None:
    with _cache_lock:
        if key in _cache:
            _cache.move_to_end(key)
            return _cache[key]
    return None


def load_inline(urdf: str, tip_frame: str | None = None, base_frame: str | None = None) -> Robot:
    """A robot from client URDF text (screened, size-limited, cached by content hash). A frame left
    out (``None``) gets its default: the root link for the base, the end of the chain for the tip.

    Raises ``InvalidURDF`` or ``TooLarge`` saying what is wrong.
    """
    given = _key(urdf, tip_frame, base_frame)
    robot = _cached(given)
    if robot is not None:
        return robot
    model, types, screened = _reduced_model(urdf, tip_frame, base_frame)
    tip_frame, base_frame = screened.tip_frame, screened.base_frame
    key = _key(urdf, tip_frame, base_frame)
    robot = _cached(key)
    if robot is not None:  # the same robot asked for with its frames named
        _store(given, robot)
        return robot
    kinds = [types[n] for n in model.names[1:]]
    vel = np.array(
        [
            v if v > 0 else DEFAULT_VELOCITY[k]
            for v, k in zip(model.velocityLimit, kinds, strict=True)
        ]
    )
    robot = Robot(
        f"inline-{key[:12]}", model, base_frame=base_frame, tip_frame=tip_frame,
        task_space=_planar_or_pose(model, tip_frame, base_frame, kinds),
        velocity_limits=np.minimum(vel, 1e4),
        acceleration_limits=np.array([DEFAULT_ACCELERATION[k] for k in kinds]),
        sources={
            "position": "the URDF (continuous joints: +-1e4 rad)",
            "velocity": "the URDF; pi rad/s or 1 m/s where it gives none",
            "acceleration": "service default: 10 rad/s^2 (revolute), 5 m/s^2 (prismatic)",
        },
        with_dynamics=has_inertials(screened.xml, screened.chain),
    )  # fmt: skip
    _store(key, robot)
    if given != key:
        _store(given, robot)
    return robot


def _store(key: str, robot: Robot) -> None:
    with _cache_lock:
        _cache[key] = robot
        _cache.move_to_end(key)
        while len(_cache) > cache_size():
            _cache.popitem(last=False)


def _planar_or_pose(model: pin.Model, tip: str, base: str, kinds: list[str]) -> str:
    """``position_xy`` when every joint moves the tip in the base x-y plane at q = 0, else ``pose``."""
    data = pin.Data(model)
    pin.forwardKinematics(model, data, pin.neutral(model))
    R_bw = pin.updateFramePlacement(
        model, data, model.getFrameId(base, pin.FrameType.BODY)
    ).rotation.T
    J = pin.computeFrameJacobian(
        model, data, pin.neutral(model), model.getFrameId(tip, pin.FrameType.BODY), pin.WORLD
    ).reshape(6, model.nv)
    for k, kind in enumerate(kinds):
        lin, ang = R_bw @ J[:3, k], R_bw @ J[3:, k]
        if kind == "revolute" and np.linalg.norm(ang[:2]) > 1e-9:
            return "pose"
        if kind == "prismatic" and abs(lin[2]) > 1e-9:
            return "pose"
    return "position_xy"


def resolve(ref: Any) -> Robot:
    """A ``Robot`` from a registered name or an inline model (a dict or an object with ``urdf`` and
    optional ``tip_frame`` and ``base_frame``: absent or ``None``, their defaults)."""
    if isinstance(ref, Robot):
        return ref
    if isinstance(ref, str):
        return get(ref)
    get_ = ref.get if isinstance(ref, dict) else lambda k: getattr(ref, k, None)
    urdf, tip, base = get_("urdf"), get_("tip_frame"), get_("base_frame")
    if not isinstance(urdf, str) or not all(v is None or isinstance(v, str) for v in (tip, base)):
        raise InputError(
            "robot must be a name or {urdf, tip_frame?, base_frame?} (strings)", field=("robot",)
        )
    return load_inline(urdf, tip, base)
