"""``PROFILES``: the joint profiles of ``POST /v1/trajectories/joint``, name -> ``ProfileKind``.

Adding a profile is one new module here (a ``ProfileKind`` subclass) and one line below; the request
schema's ``Literal`` of profile names is built from this dict.
"""

from __future__ import annotations

from core.joint.profiles.base import ProfileKind
from core.joint.profiles.jerk_limited import JerkLimited
from core.joint.profiles.linear import Linear
from core.joint.profiles.polynomial import Cubic, Quintic
from core.joint.profiles.trapezoidal import Trapezoidal

PROFILES: dict[str, ProfileKind] = {
    kind.name: kind for kind in (Linear(), Cubic(), Quintic(), Trapezoidal(), JerkLimited())
}
