"""Collision geometry of a robot in a work cell: distances and a continuous check of joint motions.

Robot geometry is a set of shapes fixed to the model's joints: the shipped robots' capsules come from
``robots.geometry``; an inline URDF's ``<collision>`` spheres, boxes and cylinders are used as they
are (exact shapes); mesh-only links are listed in ``unchecked_links`` (a warning). Obstacles are
primitives (``Obstacle``): box, sphere, cylinder, capsule, halfspace, in the robot's base frame.
The base link stands on its mount: geometry fixed to the model's root is checked for self-collision
only, never against obstacles.

Modules, one concept each:

* ``shapes``: ``Obstacle``, ``RobotCollision`` (a robot's shapes in joint frames).
* ``building``: ``robot_collision`` (shapes attached to the joints), ``link_shapes`` (back in link
  frames, for ``collision_geometry``).
* ``entries``: distances of (configuration, pair) entries: numpy closed forms, coal for box and
  cylinder pairs.
* ``motion_bound``: how fast a pair's distance can change with the joints (``motion_weights``).
* ``continuous``: the continuous check (first contact, certified ``min_clearance``, bounded memory:
  ``CHECK_WORKING_BYTES``).
* ``checker``: ``CollisionChecker``, the pairs of one robot in one work cell (``core.clearance``'s
  ``Clearance``).
* ``coal_model``: the shapes as a pinocchio ``GeometryModel``; closest pairs with witness points.
* ``dampers``: ``damper_inputs`` for the DLS QP's velocity dampers.
* ``allowed``: ``allowed_self_pairs`` and ``robot_setup`` (once per robot).

Every name below stays importable from ``robots.collision``.
"""

from robots.collision.allowed import (
    MAX_ALLOWED_WORK,
    SAMPLES_FOR_ALLOWED,
    allowed_self_pairs,
    robot_setup,
)
from robots.collision.building import MAX_CAPSULES, link_shapes, robot_collision
from robots.collision.checker import CollisionChecker
from robots.collision.continuous import (
    CHECK_WORKING_BYTES,
    CLEARANCE_TOLERANCE,
    KEY_STEP,
    MAX_KEY_ENTRIES,
    MOTION_TOLERANCE,
    Contact,
    PathCheck,
)
from robots.collision.dampers import DamperInputs, damper_inputs
from robots.collision.shapes import SHAPES, Obstacle, RobotCollision

__all__ = [
    "CHECK_WORKING_BYTES",
    "CLEARANCE_TOLERANCE",
    "KEY_STEP",
    "MAX_ALLOWED_WORK",
    "MAX_CAPSULES",
    "MAX_KEY_ENTRIES",
    "MOTION_TOLERANCE",
    "SAMPLES_FOR_ALLOWED",
    "SHAPES",
    "CollisionChecker",
    "Contact",
    "DamperInputs",
    "Obstacle",
    "PathCheck",
    "RobotCollision",
    "allowed_self_pairs",
    "damper_inputs",
    "link_shapes",
    "robot_collision",
    "robot_setup",
]
