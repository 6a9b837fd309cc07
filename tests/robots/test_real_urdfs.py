"""Defects found by running real robot descriptions (tests/fixtures/urdf/, and URDFs of the same
shapes) through the loader, the collision model and IK: each test reproduces one, against pinocchio's
own parse of the same text or a closed form."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from core.errors import InvalidURDF
from robots import ik, registry
from robots.collision import link_shapes, robot_collision, robot_setup
from robots.geometry.urdf import MIN_EXTENT
from tests.robots.inline_urdfs import joint, robot

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "urdf"


def fixture(name: str) -> str:
    return (FIXTURES / name).read_text(encoding="utf-8")


def collision(link: str, geometry: str, xyz: str = "0 0 0") -> str:
    return (
        f'<link name="{link}"><collision><origin xyz="{xyz}"/>'
        f"<geometry>{geometry}</geometry></collision></link>"
    )


def with_links(urdf: str, *links: str) -> str:
    """``urdf`` with the given ``<link>`` elements replacing the bare ones of the same names."""
    for element in links:
        name = element.split('"')[1]
        urdf = urdf.replace(f'<link name="{name}"/>', element)
    return urdf


# --- a joint named like a link (Rethink Baxter and Sawyer: joint and link "right_hand") ----------


def test_collision_primitive_on_a_link_that_shares_a_joint_name() -> None:
    # Baxter's URDF has a fixed joint "right_hand" whose child is the link "right_hand", which
    # carries collision geometry: describe answered 500 ("Several frames match the filter").
    urdf = with_links(
        robot(
            joint("j1", "base", "l1", xyz="0 0 0.3"),
            joint("right_hand", "l1", "right_hand", "fixed", xyz="0.4 0 0"),
            links=["base", "l1", "right_hand"],
        ),
        collision("right_hand", '<sphere radius="0.05"/>', xyz="0 0 0.1"),
    )
    r = registry.load_inline(urdf, "right_hand", "base")
    geometry, _ = robot_setup(r, urdf)
    assert geometry.links == ("right_hand",)
    [(link, shape, T)] = link_shapes(r, geometry)
    assert (link, shape) == ("right_hand", {"type": "sphere", "radius": 0.05})
    np.testing.assert_allclose(T[:3, 3], [0.0, 0.0, 0.1], atol=1e-15)
    # placed by FK: the sphere centre is 0.1 m above the hand, which is 0.4 m out along the arm
    q = np.array([0.7])
    hand = dict(r.link_frames(q))["right_hand"]
    np.testing.assert_allclose(
        (hand @ np.array([0, 0, 0.1, 1.0]))[:3],
        [0.4 * math.cos(0.7), 0.4 * math.sin(0.7), 0.4],
        atol=1e-12,
    )


# --- zero-size collision placeholders (Kinova Jaco fingertips, Atlas hands) ------------------------


def test_zero_size_collision_primitives_are_skipped_not_refused() -> None:
    # Kinova's Jaco URDFs give each fingertip <box size="0 0 0"/>, Atlas <sphere radius="0.0"/>:
    # the whole robot was refused (422 "a <collision> box needs 3 sizes in (0, 1000] m").
    urdf = with_links(
        robot(
            joint("j1", "base", "l1", xyz="0 0 0.3"),
            joint("j2", "l1", "tip", xyz="0.4 0 0"),
            links=["base", "l1", "tip"],
        ),
        collision("l1", '<box size="0 0 0"/>'),
        collision("tip", '<sphere radius="0.0"/>'),
    )
    r = registry.load_inline(urdf, "tip", "base")
    geometry = robot_collision(r, urdf)
    assert geometry.links == () and geometry.unchecked_links == ()
    # a flat box is kept as a box (a plate with extent in two axes), MIN_EXTENT thin
    flat = urdf.replace('<box size="0 0 0"/>', '<box size="0.2 0.1 0"/>')
    geometry = robot_collision(registry.load_inline(flat, "tip", "base"), flat)
    assert geometry.links == ("l1",)
    np.testing.assert_allclose(geometry.dims, [[0.1, 0.05, MIN_EXTENT / 2]])
    for bad in ('<box size="0 -1 0"/>', '<sphere radius="nan"/>', '<cylinder radius="1"/>'):
        broken = urdf.replace('<box size="0 0 0"/>', bad)
        with pytest.raises(InvalidURDF):  # a URDF rejection is invalid_urdf, not validation
            robot_collision(registry.load_inline(broken, "tip", "base"), broken)


# --- limits without lower/upper (example-robot-data's quadruped) ------------------------------------


def test_missing_limit_bounds_are_zero_as_pinocchio_parses_them() -> None:
    # <limit effort="1000" velocity="10000"/> on a revolute knee: the URDF specification's default
    # for a missing lower or upper is 0; the service refused the robot (422).
    urdf = fixture("quadruped.urdf")
    r = registry.load_inline(urdf, "FL_contact", "base_link")
    reference = pin.buildModelFromXML(urdf)
    for k, name in enumerate(r.joint_names):
        jq = reference.joints[reference.getJointId(name)].idx_q
        assert r.position_limits[k].tolist() == [
            reference.lowerPositionLimit[jq],
            reference.upperPositionLimit[jq],
        ]
    assert r.position_limits[r.joint_names.index("FL_KFE")].tolist() == [0.0, 0.0]
    only_upper = robot(
        joint("j", "l0", "l1", limit='<limit upper="1.5" velocity="1" effort="1"/>'),
        links=["l0", "l1"],
    )
    assert registry.load_inline(only_upper, "l1", "l0").position_limits.tolist() == [[0.0, 1.5]]


def test_reversed_limits_off_the_chain_are_harmless() -> None:
    # A pan-tilt unit beside the arm with lower="2.775" upper="-2.775" (Adept's Pioneer LX with a
    # Jaco): the joint is locked at 0 for this chain, yet the robot was refused.
    reversed_limit = '<limit lower="2.775" upper="-2.775" velocity="1" effort="1"/>'
    urdf = robot(
        joint("j1", "base", "l1"),
        joint("ptu_pan", "base", "ptu", limit=reversed_limit),
        links=["base", "l1", "ptu"],
    )
    assert registry.load_inline(urdf, "l1", "base").joint_names == ("j1",)
    with pytest.raises(InvalidURDF, match="lower limit > upper limit"):
        registry.load_inline(urdf, "ptu", "base")


# --- IK at a singular pose of a labelled arm (PyBullet's two-joint robot, stretched out) -----------


def test_singular_pose_gives_one_solution_per_label() -> None:
    # At q = 0 the planar arm is stretched; the numeric search's seeds converge to points a few
    # 1e-6 rad apart on both sides of the singularity, and ik all returned four "distinct"
    # solutions, two labelled "down" and two "up" (the doc: distinct solutions never share a label).
    r = registry.load_inline(fixture("two_joint_robot.urdf"), "link_23_cyl", "base_link")
    assert r.configuration_family is not None
    for seed in (r.home, np.array([1.0, 1.0]), np.array([-2.0, 0.5])):
        sols = ik.ik_all(r, r.fk(np.zeros(2)), seed=seed)
        assert len(set(sols.configurations)) == len(sols.configurations) >= 1
        assert np.all(sols.position_errors <= 1e-9)
        # every one is the stretched arm (the pose has one solution, modulo the elbow's sign)
        np.testing.assert_allclose(sols.positions, 0.0, atol=1e-4)
    # away from the singularity: the two elbow branches, mirror images of each other
    q = np.array([0.5, 1.0])
    sols = ik.ik_all(r, r.fk(q), seed=q)
    assert sorted(sols.configurations) == ["down", "up"]
    np.testing.assert_allclose(sols.positions[0], q, atol=1e-9)
    np.testing.assert_allclose(sols.positions[1], [1.5, -1.0], atol=1e-9)  # l1 = l2: q1 + q2, -q2


# --- an encoding declaration in text that arrived decoded -------------------------------------------


@pytest.mark.parametrize("declared", ["ISO-8859-1", "UTF-16", "ascii", "utf-8"])
def test_encoding_declaration_does_not_re_decode_the_text(declared: str) -> None:
    # The URDF arrives as a JSON string (already text); parsing its UTF-8 bytes under an
    # ISO-8859-1 declaration turned the link "outil_ø" into "outil_Ã¸" (tip_frame named no link),
    # and a UTF-16 declaration made the text unreadable.
    tip = "outil_\N{LATIN SMALL LETTER O WITH STROKE}"
    urdf = robot(joint("j1", "base", tip, xyz="0.3 0 0"), links=["base", tip]).replace(
        '<?xml version="1.0"?>', f'<?xml version="1.0" encoding="{declared}"?>'
    )
    r = registry.load_inline(urdf, tip, "base")
    assert r.joint_names == ("j1",)
    np.testing.assert_allclose(r.fk(np.array([0.5]))[:3, 3], [0.3, 0.0, 0.0], atol=1e-15)


# --- analytic IK at a singular pose whose representatives lie outside the limits ------------------


def test_analytic_ik_finds_the_stretched_out_home_inside_the_limits() -> None:
    # PyBullet's iiwa at q = 0 (its home: stretched straight up, singular). EAIK, joint 7 held at
    # 0, returned representatives of the continuum of solutions with joint 2 outside its limits
    # only: IK of the home pose, seeded at home, answered 422 joint_limit.
    r = registry.load_inline(fixture("kuka_iiwa.urdf"), "lbr_iiwa_link_7", "lbr_iiwa_link_0")
    assert r.ik_solver == "analytic" and np.all(r.home == 0.0)
    T = r.fk(r.home)
    sols = ik.ik_all(r, T)
    assert sols.solver == "analytic" and len(sols)
    np.testing.assert_allclose(sols.positions[0], r.home, atol=1e-9)
    lo, hi = r.position_limits.T
    assert np.all((sols.positions >= lo) & (sols.positions <= hi))
    reference = pin.buildModelFromXML(fixture("kuka_iiwa.urdf"))
    data = reference.createData()
    tip = reference.getFrameId("lbr_iiwa_link_7", pin.FrameType.BODY)
    for q in sols.positions:
        pin.framesForwardKinematics(reference, data, q)
        np.testing.assert_allclose(data.oMf[tip].homogeneous, T, atol=1e-9)


# --- a 7R arm whose held joint decomposes only at 0 -------------------------------------------------


def test_7r_analytic_ik_holds_a_joint_that_decomposes_at_every_value() -> None:
    # The LBR iiwa 14 R820 (kuka_experimental): with joint a6 held at 0, axes 5 and 7 line up and
    # EAIK decomposes the rest; at any other a6 it does not, yet a6 was chosen (probed at 0 only)
    # and the "analytic" solver missed the configuration a pose came from (2 of 60 poses).
    r = registry.load_inline(fixture("lbr_iiwa_14_r820.urdf"), "tool0", "base_link")
    assert r.ik_solver == "analytic" and r.redundant_joints != ("joint_a6",)
    held = [r.joint_names.index(n) for n in r.redundant_joints]
    lo, hi = r.position_limits.T
    rng = np.random.default_rng(3)
    for _ in range(60):
        q = lo + (hi - lo) * rng.random(7)
        fixed = {r.joint_names[j]: float(q[j]) for j in held}
        sols = ik.ik_all(r, r.fk(q), seed=r.home, fixed_joints=fixed)
        assert sols.solver == "analytic"
        d = np.abs((sols.positions - q + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
        assert d.min() < 1e-6, q  # near a4 = 0 the held chain is ill-conditioned: 3e-7
