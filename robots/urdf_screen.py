"""Screening of client URDF text before pinocchio sees it.

Rules, checked in this order (each rejection says what is wrong and never echoes the offending value):

1. At most 1 MiB of UTF-8 (``TooLarge``).
2. A cheap scan before any XML parsing: more than ``2 * MAX_JOINTS`` ``<joint`` tags is ``TooLarge``
   (twice the joint bound leaves room for the ``<joint>`` references inside ``<transmission>``), so
   a 4,000-joint chain never reaches the parser.
3. defusedxml with DTDs, entities and external references forbidden: an entity-expansion bomb stops
   at its ``<!DOCTYPE`` (``InvalidURDF``), as does XML that is not well formed.
4. A ``<robot>`` root; unique link and joint names; at most ``MAX_JOINTS`` joints (``TooLarge``).
5. Joint types: revolute, prismatic, continuous and fixed only; parent and child links exist; the
   links form one tree (one root, every link has at most one parent, no cycles).
6. Numbers: origins and axes are finite (``|xyz| <= 1e4`` m), axes non-zero; revolute and prismatic
   joints have a ``<limit>`` with finite bounds (a missing bound is 0, as the URDF specification,
   urdfdom and pinocchio have it), ``lower <= upper`` on the robot's chain (joints off it are
   locked at 0, so a reversed range there, as in real URDFs' pan-tilt units, is harmless); velocity and effort limits, when present, are 0
   (no limit given: the service's default) or >= 1e-6 like a request's limits, so no URDF limit
   can overflow a ratio (a 1e-300 rad/s limit made spline knot times infinite: HTTP 500).
7. ``tip_frame`` and ``base_frame`` are links; the base is fixed to the root (no movable joint between
   them); at least one movable joint lies between the root and the tip.

Frames left out (``None``) get defaults (``default_tip``): the base is the root link; the tip is the
end of the chain below the base. That needs the movable joints below the base to form one chain:
every leaf link reached through movable joints (then fixed ones) has the same movable joints on its
way, or a prefix of the longest such list (a sensor fixed to a middle link is not another chain).
Of the leaves after the last movable joint, ``tool0`` (REP 199's flange frame, ROS-Industrial's tool
frame) is taken when it is one of them, else the deepest (most fixed joints after that joint). A
tree that branches through movable joints (a hand with fingers, two arms, legs) or ends in several
equally deep leaves has no unique tip: ``InvalidURDF`` at ``robot.tip_frame`` listing the candidates.

The screened model is rewritten as a minimal URDF (links with their checked ``<inertial>``, see
``robots.dynamics.screened_inertial``, and joints with their effort limits): ``<visual>``,
``<collision>``, ``<transmission>``, ``<mimic>`` and every other element are dropped,
so meshes are never loaded. Continuous joints become revolute joints with position limits
``+-CONTINUOUS_LIMIT`` (1e4 rad, the API's position bound), because pinocchio's continuous joint has a
2-number configuration (cos, sin). Position limits are clamped to ``+-1e4``. Missing or zero velocity
limits stay 0 here; ``robots.registry`` fills in its documented defaults.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import defusedxml.ElementTree as DET
from defusedxml import DefusedXmlException

from core.errors import InvalidURDF, TooLarge
from robots.dynamics import screened_inertial

MAX_URDF_BYTES = 1024 * 1024
MAX_JOINTS = 64
MAX_COORDINATE = 1e4
"""Largest |origin coordinate| [m] and |joint position limit| [rad or m] accepted."""
CONTINUOUS_LIMIT = 1e4
"""Position limits [rad] given to a continuous joint (pinocchio models it as bounded revolute)."""
MIN_RATE_LIMIT = 1e-6
"""Smallest non-zero velocity [rad/s or m/s] or effort [N m or N] limit accepted: the lower bound of
a request's ``limits`` (``service.schemas.common.MIN_LIMIT``); tinier ones overflow ratios."""
JOINT_TYPES = ("revolute", "prismatic", "continuous", "fixed")
FIELD = ("robot", "urdf")
_JOINT_TAG = re.compile(r"<joint[\s/>]")


@dataclass(frozen=True)
class ScreenedURDF:
    """A URDF that passed screening.

    Attributes:
        xml: Minimal URDF (links and joints only) for pinocchio.
        chain: Movable joint names on the path root -> tip, root first.
        joint_types: Type of each movable joint on the chain (after continuous -> revolute), by name.
        continuous: Names of the joints converted from continuous to revolute.
        link_names: Every link, in document order.
        tip_frame: The tool frame: the one asked for, or the default (see the module docstring).
        base_frame: The base frame: the one asked for, or the root link.
    """

    xml: str
    chain: tuple[str, ...]
    joint_types: dict[str, str]
    continuous: tuple[str, ...]
    link_names: tuple[str, ...]
    tip_frame: str
    base_frame: str


def _name(s: str) -> str:
    """A name for an error message, shortened."""
    return s if len(s) <= 64 else s[:61] + "..."


def floats(text: str | None, n: int, what: str, default: tuple[float, ...]) -> tuple[float, ...]:
    """``n`` finite numbers from a URDF attribute (``default`` when absent); ``InvalidURDF`` naming
    ``what`` otherwise. The one parser of numeric URDF attributes (joints here, ``<collision>``
    elements in ``robots.geometry.urdf``)."""
    if text is None:
        return default
    try:
        values = tuple(float(v) for v in text.split())
    except ValueError:
        raise InvalidURDF(f"{what} is not a list of numbers", field=FIELD) from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise InvalidURDF(f"{what} needs {n} finite numbers", field=FIELD)
    return values


def _parse(urdf: str) -> ET.Element:
    """Parse with DTDs, entities and external references forbidden. The text is parsed as text:
    it arrived decoded (JSON), so an ``encoding="ISO-8859-1"`` declaration in it must not make the
    parser decode its UTF-8 bytes again (a link named "outil_ø" came out as two Latin-1
    characters, so tip_frame named no link)."""
    try:
        return DET.fromstring(urdf, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DefusedXmlException:
        raise InvalidURDF(
            "URDF with a DTD, entity declarations or external references is refused", field=FIELD
        ) from None
    except ET.ParseError as e:
        line, col = getattr(e, "position", (0, 0))
        raise InvalidURDF(
            f"URDF is not well-formed XML (line {line}, column {col})", field=FIELD
        ) from None


def _precheck(urdf: str) -> None:
    size = len(urdf.encode("utf-8"))
    if size > MAX_URDF_BYTES:
        raise TooLarge(
            f"URDF is {size} bytes; at most {MAX_URDF_BYTES} (1 MiB) are accepted",
            field=FIELD,
            extra={"limit_bytes": MAX_URDF_BYTES},
        )
    tags = len(_JOINT_TAG.findall(urdf))
    if tags > 2 * MAX_JOINTS:
        raise TooLarge(
            f"URDF has {tags} <joint> tags; a robot may have at most {MAX_JOINTS} joints",
            field=FIELD,
            extra={"limit_joints": MAX_JOINTS},
        )


def _joint_xml(j: ET.Element, jname: str, jtype: str) -> tuple[ET.Element, str]:
    """Checked, minimal copy of one <joint>; returns it and its type after conversion."""
    where = f"joint '{_name(jname)}'"
    org = j.find("origin")
    xyz = floats(None if org is None else org.get("xyz"), 3, f"{where} origin xyz", (0.0,) * 3)
    rpy = floats(None if org is None else org.get("rpy"), 3, f"{where} origin rpy", (0.0,) * 3)
    if max(abs(v) for v in xyz + rpy) > MAX_COORDINATE:
        raise InvalidURDF(f"{where} origin is beyond 1e4 (m or rad)", field=FIELD)
    out = ET.Element("joint", name=jname, type="revolute" if jtype == "continuous" else jtype)
    for end in ("parent", "child"):  # both checked to name existing links by the caller
        element = j.find(end)
        ET.SubElement(out, end, link=(element.get("link") if element is not None else None) or "")
    ET.SubElement(out, "origin", xyz=" ".join(map(repr, xyz)), rpy=" ".join(map(repr, rpy)))
    if jtype == "fixed":
        return out, jtype
    ax = j.find("axis")
    axis = floats(None if ax is None else ax.get("xyz"), 3, f"{where} axis", (1.0, 0.0, 0.0))
    norm = math.sqrt(sum(v * v for v in axis))
    if not 1e-9 < norm <= MAX_COORDINATE:
        raise InvalidURDF(f"{where} has a zero or oversized axis", field=FIELD)
    ET.SubElement(out, "axis", xyz=" ".join(repr(v / norm) for v in axis))
    lim = j.find("limit")
    velocity = _rate_limit(lim, "velocity", where)
    effort = _rate_limit(lim, "effort", where)
    if jtype == "continuous":
        lower, upper = -CONTINUOUS_LIMIT, CONTINUOUS_LIMIT
    else:
        if lim is None:
            raise InvalidURDF(f"{where} ({jtype}) needs a <limit> element", field=FIELD)
        # the URDF specification's defaults (urdfdom, pinocchio): a missing bound is 0
        (lower,) = floats(lim.get("lower"), 1, f"{where} lower limit", (0.0,))
        (upper,) = floats(lim.get("upper"), 1, f"{where} upper limit", (0.0,))
        lower, upper = max(lower, -MAX_COORDINATE), min(upper, MAX_COORDINATE)
    ET.SubElement(
        out, "limit", lower=repr(lower), upper=repr(upper), velocity=repr(velocity),
        effort=repr(effort),
    )  # fmt: skip
    return out, "revolute" if jtype == "continuous" else jtype


def _rate_limit(lim: ET.Element | None, attribute: str, where: str) -> float:
    """A joint's ``velocity`` or ``effort`` limit: 0 when absent or 0 (the registry's default
    applies), else finite and >= ``MIN_RATE_LIMIT``, the lower bound of a request's limits (larger
    velocity limits are clamped to 1e4 by the registry, as before)."""
    if lim is None or lim.get(attribute) is None:
        return 0.0
    (value,) = floats(lim.get(attribute), 1, f"{where} {attribute} limit", (0.0,))
    if value < 0:
        raise InvalidURDF(f"{where} has a negative {attribute} limit", field=FIELD)
    if 0.0 < value < MIN_RATE_LIMIT:
        raise InvalidURDF(
            f"{where} has a {attribute} limit below {MIN_RATE_LIMIT:g}, the smallest a request "
            "may give (0 or no attribute: the service's default)",
            field=FIELD,
        )
    return value


def _links_and_joints(root: ET.Element) -> tuple[list[str], list[ET.Element]]:
    if root.tag != "robot":
        raise InvalidURDF("the root element of a URDF must be <robot>", field=FIELD)
    links = [el.get("name", "") for el in root.findall("link")]
    joints = root.findall("joint")
    if len(joints) > MAX_JOINTS:
        raise TooLarge(
            f"URDF has {len(joints)} joints; at most {MAX_JOINTS} are accepted",
            field=FIELD,
            extra={"limit_joints": MAX_JOINTS},
        )
    if not links or any(not n for n in links):
        raise InvalidURDF("every <link> needs a non-empty name, and a URDF needs one", field=FIELD)
    if len(set(links)) != len(links):
        raise InvalidURDF("link names must be unique", field=FIELD)
    names = [j.get("name", "") for j in joints]
    if any(not n for n in names) or len(set(names)) != len(names):
        raise InvalidURDF("every <joint> needs a unique, non-empty name", field=FIELD)
    return links, joints


MAX_LISTED = 16
"""Most candidate tips named in an error message (the ``candidates`` field lists every one)."""


def default_tip(base: str, children: dict[str, list[tuple[str, str]]], order: list[str]) -> str:
    """The end of the chain below ``base`` (rules in the module docstring); ``InvalidURDF`` at
    ``robot.tip_frame`` when there is none or no unique one.

    Args:
        children: Link -> ``(joint type, child link)`` of each joint whose parent it is.
        order: Every link in document order (the order candidates are listed in).
    """
    # (leaf, the child links of the movable joints on the way, fixed joints after the last one)
    leaves: list[tuple[str, tuple[str, ...], int]] = []
    stack: list[tuple[str, tuple[str, ...], int]] = [(base, (), 0)]
    while stack:  # the links form a tree (checked before): every link is visited once
        link, movable, depth = stack.pop()
        if not children.get(link) and movable:
            leaves.append((link, movable, depth))
        for jtype, child in children.get(link, []):
            if jtype == "fixed":
                stack.append((child, movable, depth + 1))
            else:
                stack.append((child, (*movable, child), 0))
    field = ("robot", "tip_frame")
    if not leaves:
        raise InvalidURDF(
            "no movable joint lies below base_frame, so there is no chain to default tip_frame to",
            field=field,
        )
    index = {name: k for k, name in enumerate(order)}
    longest = max((m for _, m, _ in leaves), key=len)
    one_chain = all(m == longest[: len(m)] for _, m, _ in leaves)
    ends = [(leaf, depth) for leaf, m, depth in leaves if m == longest] if one_chain else []
    if any(leaf == "tool0" for leaf, _ in ends):
        return "tool0"
    deepest = max((d for _, d in ends), default=-1)
    tips = [leaf for leaf, d in ends if d == deepest]
    if len(tips) == 1:
        return tips[0]
    candidates = sorted((leaf for leaf, _ in ends) if ends else (leaf for leaf, _, _ in leaves),
                        key=index.__getitem__)  # fmt: skip
    named = ", ".join(_name(c) for c in candidates[:MAX_LISTED])
    why = "ends in several equally deep links" if one_chain else "branches through movable joints"
    raise InvalidURDF(
        f"the URDF {why} below base_frame, so it has no unique tip; name tip_frame, one of "
        f"{len(candidates)} leaf links: {named}{', ...' if len(candidates) > MAX_LISTED else ''}",
        field=field,
        extra={"candidates": candidates},
    )


@dataclass
class _Tree:
    """The screened joints: the minimal URDF, each child link's (joint, type, parent link), each
    parent link's (type, child link) list, joint types after conversion, continuous joints."""

    out: ET.Element
    parent_of: dict[str, tuple[str, str, str]] = field(default_factory=dict)
    children: dict[str, list[tuple[str, str]]] = field(default_factory=dict)
    types: dict[str, str] = field(default_factory=dict)
    continuous: list[str] = field(default_factory=list)

    def path_to_root(self, link: str, limit: int) -> list[tuple[str, str]]:
        """``(joint, type)`` from ``link`` up to the root; ``InvalidURDF`` on a cycle."""
        path: list[tuple[str, str]] = []
        while link in self.parent_of:
            jname, jtype, link = self.parent_of[link]
            path.append((jname, jtype))
            if len(path) > limit:
                raise InvalidURDF("the joints form a cycle", field=FIELD)
        return path


def _tree(
    links: list[str], joints: list[ET.Element], inertials: dict[str, ET.Element | None]
) -> _Tree:
    """Every joint checked and copied (``_joint_xml``), each link with its checked ``<inertial>``
    (``robots.dynamics.screened_inertial``), the links linked into a tree."""
    link_set = set(links)
    tree = _Tree(ET.Element("robot", name="screened"))
    for name in links:
        inertial = screened_inertial(inertials[name], name)
        ET.SubElement(tree.out, "link", name=name).extend([] if inertial is None else [inertial])
    for j in joints:
        jname, jtype = j.get("name", ""), j.get("type", "")
        if jtype not in JOINT_TYPES:
            raise InvalidURDF(
                f"joint '{_name(jname)}' has an unsupported type; allowed: {', '.join(JOINT_TYPES)}",
                field=FIELD,
            )
        par, chi = j.find("parent"), j.find("child")
        plink = None if par is None else par.get("link")
        clink = None if chi is None else chi.get("link")
        if plink is None or clink is None or plink not in link_set or clink not in link_set:
            raise InvalidURDF(
                f"joint '{_name(jname)}' names a parent or child link that does not exist",
                field=FIELD,
            )
        if clink in tree.parent_of:
            raise InvalidURDF(
                f"link '{_name(clink)}' is the child of more than one joint", field=FIELD
            )
        element, tree.types[jname] = _joint_xml(j, jname, jtype)
        if jtype == "continuous":
            tree.continuous.append(jname)
        tree.parent_of[clink] = (jname, tree.types[jname], plink)
        tree.children.setdefault(plink, []).append((tree.types[jname], clink))
        tree.out.append(element)
    return tree


def _check_frames(links: list[str], tip_frame: str | None, base_frame: str) -> None:
    """Both frames name links (the tip reported first when both are given)."""
    available = {"links": links[: 2 * MAX_JOINTS]}
    frames: tuple[tuple[str, str | None], ...] = (
        ("base_frame", base_frame),
        ("tip_frame", tip_frame),
    )
    if tip_frame is not None:  # both given: the tip is reported first, as it always was
        frames = frames[::-1]
    for fname, frame in frames:
        if frame is not None and frame not in links:
            raise InvalidURDF(
                f"{fname} names no link of the URDF", field=("robot", fname), extra=available
            )


def screen_urdf(urdf: str, tip_frame: str | None, base_frame: str | None) -> ScreenedURDF:
    """Check ``urdf`` against every rule above; raise ``InvalidURDF`` or ``TooLarge`` on the first
    broken one, else return the minimal URDF and the movable chain from the root to ``tip_frame``.
    A frame given as ``None`` gets its default (``default_tip``, the root link for the base)."""
    _precheck(urdf)
    root = _parse(urdf)
    links, joints = _links_and_joints(root)
    inertials = {el.get("name", ""): el.find("inertial") for el in root.findall("link")}
    tree = _tree(links, joints, inertials)
    roots = [name for name in links if name not in tree.parent_of]
    if len(roots) != 1:
        raise InvalidURDF(
            f"the links must form one tree; found {len(roots)} root links", field=FIELD
        )
    for link in links:  # a cycle leaves some link unreachable from the single root
        tree.path_to_root(link, len(links))
    base_frame = roots[0] if base_frame is None else base_frame
    _check_frames(links, tip_frame, base_frame)
    if any(t != "fixed" for _, t in tree.path_to_root(base_frame, len(links))):
        raise InvalidURDF(
            "base_frame must be fixed to the URDF's root link (a movable joint lies between them)",
            field=("robot", "base_frame"),
        )
    if tip_frame is None:
        tip_frame = default_tip(base_frame, tree.children, links)
    path = tree.path_to_root(tip_frame, len(links))
    chain = tuple(j for j, t in reversed(path) if t != "fixed")
    if not chain:
        raise InvalidURDF(
            "no movable joint lies between the root and tip_frame", field=("robot", "tip_frame")
        )
    for element in tree.out.iter("joint"):  # joints off the chain are locked at 0: range is moot
        limit = element.find("limit")
        if element.get("name") in chain and limit is not None:
            if float(limit.get("lower", "0")) > float(limit.get("upper", "0")):
                raise InvalidURDF(
                    f"joint '{_name(element.get('name', ''))}' has lower limit > upper limit",
                    field=FIELD,
                )
    return ScreenedURDF(
        xml=ET.tostring(tree.out, encoding="unicode"),
        chain=chain,
        joint_types={j: tree.types[j] for j in chain},
        continuous=tuple(tree.continuous),
        link_names=tuple(links),
        tip_frame=tip_frame,
        base_frame=base_frame,
    )
