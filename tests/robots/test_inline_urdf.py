"""Client URDFs: what loads, what is cached, and a test for every screening rule."""

from __future__ import annotations

import time
from importlib import resources

import numpy as np
import pytest

from core.errors import InvalidURDF, TooLarge
from robots import registry, urdf_screen
from tests.robots.inline_urdfs import OFFSET_BASE_URDF, chain, joint, robot

UR5_URDF = resources.files("robots").joinpath("urdf", "ur5.urdf").read_text()


def reject(urdf: str, message: str, tip: str = "l1", base: str = "l0", error=InvalidURDF) -> None:
    with pytest.raises(error) as err:
        registry.load_inline(urdf, tip, base)
    assert message in err.value.detail, err.value.detail
    assert err.value.field is not None


# --- what loads ----------------------------------------------------------------------------------


def test_inline_ur5_equals_the_shipped_one() -> None:
    inline, shipped = registry.load_inline(UR5_URDF, "tool0", "base_link"), registry.get("ur5")
    assert inline.name.startswith("inline-") and inline.joint_names == shipped.joint_names
    qs = np.random.default_rng(0).uniform(-3, 3, (200, 6))
    assert np.abs(inline.fk_many(qs) - shipped.fk_many(qs)).max() <= 1e-12
    np.testing.assert_allclose(inline.velocity_limits, shipped.velocity_limits)
    assert inline.task_space == "pose"


def test_chain_only_fingers_locked_continuous_converted_defaults() -> None:
    r = registry.load_inline(OFFSET_BASE_URDF, "tool", "mount")
    assert r.joint_names == ("j1", "j2", "slide", "wrist") and r.dof == 4
    np.testing.assert_allclose(r.position_limits[3], [-1e4, 1e4])  # continuous -> +-1e4 rad
    np.testing.assert_allclose(r.velocity_limits, [2, 2, 0.5, np.pi])  # wrist: no velocity -> pi
    np.testing.assert_allclose(r.acceleration_limits, [10, 10, 5, 10])
    np.testing.assert_allclose(r.home, [0, 0, 0, 0])
    assert r.revolute.tolist() == [True, True, False, True]
    # fk_many (numpy chain) and pinocchio agree; the base frame is the offset, rotated mount
    qs = np.random.default_rng(1).uniform(
        r.position_limits[:, 0], np.minimum(r.position_limits[:, 1], 3), (100, 4)
    )
    assert np.abs(r.fk_many(qs) - np.array([r.fk(q) for q in qs])).max() <= 1e-12
    world = registry.load_inline(OFFSET_BASE_URDF, "tool", "world")
    T_world_mount = world.frame_pose(np.zeros(4), "mount")
    np.testing.assert_allclose(T_world_mount @ r.fk(qs[0]), world.fk(qs[0]), atol=1e-12)


def test_meshes_are_stripped_and_never_loaded() -> None:
    screened = urdf_screen.screen_urdf(OFFSET_BASE_URDF, "tool", "mount")
    for word in ("mesh", "visual", "collision", "passwd", "package://"):
        assert word not in screened.xml


def test_planar_inline_model_gets_position_xy() -> None:
    from tests.robots.inline_urdfs import PLANAR_3R_URDF

    assert registry.load_inline(PLANAR_3R_URDF, "tip", "base").task_space == "position_xy"


def test_cache_by_content_hash_and_lru_size(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(registry, "_cache", type(registry._cache)())
    monkeypatch.setenv("TRAJ_URDF_CACHE_SIZE", "2")
    a = registry.load_inline(chain(2), "l2", "l0")
    assert registry.load_inline(chain(2), "l2", "l0") is a
    assert registry.load_inline(chain(2), "l1", "l0") is not a  # the tip is part of the key
    registry.load_inline(chain(3), "l3", "l0")  # evicts the least recently used (a)
    assert len(registry._cache) == 2
    assert registry.load_inline(chain(2), "l2", "l0") is not a
    assert registry.resolve({"urdf": chain(2), "tip_frame": "l2", "base_frame": "l0"}).dof == 2


# --- size and parser safety ----------------------------------------------------------------------


def test_more_than_1_mib_is_too_large() -> None:
    urdf = chain(2).replace("</robot>", "<!--" + "x" * (1024 * 1024) + "--></robot>")
    reject(urdf, "1 MiB", error=TooLarge)


def test_4000_joint_chain_is_rejected_before_parsing(monkeypatch: pytest.MonkeyPatch) -> None:
    urdf = chain(4000)
    assert len(urdf.encode()) < 1024 * 1024

    def no_parsing(*args, **kwargs):
        raise AssertionError("the XML parser must not run")

    monkeypatch.setattr(urdf_screen.DET, "fromstring", no_parsing)
    start = time.perf_counter()
    reject(urdf, "at most 64 joints", tip="l4000", error=TooLarge)
    assert time.perf_counter() - start < 0.5


def test_65_joints_are_too_many() -> None:
    reject(chain(65), "at most 64", tip="l65", error=TooLarge)
    assert registry.load_inline(chain(64), "l64", "l0").dof == 64


def test_billion_laughs_is_rejected_in_well_under_a_second() -> None:
    entities = "".join(
        f'<!ENTITY lol{i} "{("&lol" + str(i - 1) + ";") * 10}">' for i in range(1, 10)
    )
    bomb = f'<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY lol0 "lol">{entities}]><robot name="&lol9;"/>'
    start = time.perf_counter()
    reject(bomb, "DTD, entity")
    assert time.perf_counter() - start < 0.1


def test_external_entity_is_rejected() -> None:
    xxe = '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]><robot name="&x;"/>'
    reject(xxe, "DTD, entity")


def test_not_well_formed() -> None:
    reject("<robot name='x'><link name='a'></robot>", "not well-formed")


def test_root_must_be_robot() -> None:
    reject("<sdf><link name='l0'/></sdf>", "<robot>")


# --- structure ------------------------------------------------------------------------------------


def test_unsupported_joint_types() -> None:
    for jtype in ("floating", "planar", "spherical"):
        reject(robot(joint("j", "l0", "l1", jtype), links=["l0", "l1"]), "unsupported type")


def test_missing_parent_or_child_link() -> None:
    reject(robot(joint("j", "l0", "ghost"), links=["l0", "l1"]), "does not exist")


def test_duplicate_names() -> None:
    reject(robot(joint("j", "l0", "l1"), links=["l0", "l1", "l1"]), "link names must be unique")
    two = robot(joint("j", "l0", "l1"), joint("j", "l1", "l2"), links=["l0", "l1", "l2"])
    reject(two, "unique, non-empty name")


def test_link_with_two_parents() -> None:
    urdf = robot(joint("a", "l0", "l1"), joint("b", "l2", "l1"), links=["l0", "l1", "l2"])
    reject(urdf, "child of more than one joint")


def test_two_roots_and_cycles() -> None:
    reject(robot(joint("a", "l0", "l1"), links=["l0", "l1", "loose"]), "one tree")
    ring = [joint("a", "l0", "l1"), joint("b", "l1", "l2"), joint("c", "l2", "l0")]
    reject(robot(*ring, links=["l0", "l1", "l2"]), "one tree")  # no root at all
    ring = [joint("a", "l1", "l2"), joint("b", "l2", "l3"), joint("c", "l3", "l1")]
    reject(robot(*ring, links=["l0", "l1", "l2", "l3"]), "cycle")  # a root, and a detached ring


# --- numbers ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "abc", "1e400"])
def test_limits_must_be_finite(bad: str) -> None:
    lim = f'<limit lower="{bad}" upper="1" velocity="1" effort="1"/>'
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(
            robot(joint("j", "l0", "l1", limit=lim), links=["l0", "l1"]), "l1", "l0"
        )
    assert "lower limit" in err.value.detail and bad not in err.value.detail


def test_lower_above_upper() -> None:
    lim = '<limit lower="1" upper="-1" velocity="1" effort="1"/>'
    reject(
        robot(joint("j", "l0", "l1", limit=lim), links=["l0", "l1"]), "lower limit > upper limit"
    )


def test_revolute_and_prismatic_need_limits() -> None:
    for jtype in ("revolute", "prismatic"):
        reject(robot(joint("j", "l0", "l1", jtype, limit=""), links=["l0", "l1"]), "needs a <limit")


def test_negative_or_non_finite_velocity_limit() -> None:
    for v, msg in (("-1", "negative velocity"), ("nan", "velocity limit")):
        lim = f'<limit lower="-1" upper="1" velocity="{v}" effort="1"/>'
        reject(robot(joint("j", "l0", "l1", limit=lim), links=["l0", "l1"]), msg)


def test_zero_velocity_limit_gets_the_default() -> None:
    lim = '<limit lower="-1" upper="1" velocity="0" effort="1"/>'
    r = registry.load_inline(
        robot(joint("j", "l0", "l1", limit=lim), links=["l0", "l1"]), "l1", "l0"
    )
    assert r.velocity_limits.tolist() == [np.pi]


def test_bad_origin_and_axis() -> None:
    reject(robot(joint("j", "l0", "l1", xyz="0 nan 0"), links=["l0", "l1"]), "origin xyz")
    reject(robot(joint("j", "l0", "l1", xyz="0 0"), links=["l0", "l1"]), "origin xyz")
    reject(robot(joint("j", "l0", "l1", xyz="0 0 1e5"), links=["l0", "l1"]), "beyond 1e4")
    reject(
        robot(joint("j", "l0", "l1", axis="0 0 0"), links=["l0", "l1"]), "zero or oversized axis"
    )


# --- frames ----------------------------------------------------------------------------------------


def test_tip_and_base_must_exist() -> None:
    urdf = chain(2)
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(urdf, "nope", "l0")
    assert err.value.field == ("robot", "tip_frame") and "nope" not in err.value.detail
    assert err.value.extra["links"] == ["l0", "l1", "l2"]
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(urdf, "l2", "nope")
    assert err.value.field == ("robot", "base_frame")


def test_base_must_be_fixed_to_the_root() -> None:
    reject(chain(3), "base_frame must be fixed", tip="l3", base="l1")


def test_a_movable_joint_must_lie_before_the_tip() -> None:
    urdf = robot(joint("f", "l0", "l1", "fixed"), joint("j", "l1", "l2"), links=["l0", "l1", "l2"])
    reject(urdf, "no movable joint", tip="l1")


# --- default frames --------------------------------------------------------------------------------


def test_default_base_is_the_root_and_default_tip_the_end_of_the_chain() -> None:
    # a sensor fixed to a middle link is no second chain; of the links after the last joint the
    # deepest is the tip (tool_tip, two fixed joints after j3)
    urdf = robot(
        joint("j1", "root", "l1"),
        joint("j2", "l1", "l2", xyz="0.4 0 0"),
        joint("cam", "l2", "camera", "fixed", xyz="0 0.1 0"),
        joint("j3", "l2", "l3", xyz="0.3 0 0"),
        joint("flange", "l3", "flange", "fixed", xyz="0.1 0 0"),
        joint("tool", "flange", "tool_tip", "fixed", xyz="0.05 0 0"),
        joint("marker", "l3", "marker", "fixed", xyz="0 0 0.02"),
        links=["root", "l1", "l2", "camera", "l3", "flange", "tool_tip", "marker"],
    )
    screened = urdf_screen.screen_urdf(urdf, None, None)
    assert (screened.base_frame, screened.tip_frame) == ("root", "tool_tip")
    assert screened.chain == ("j1", "j2", "j3")
    # the same robot as with the frames named: one cache entry's robot, one name
    named = registry.load_inline(urdf, "tool_tip", "root")
    assert registry.load_inline(urdf) is named
    assert registry.resolve({"urdf": urdf, "tip_frame": None}) is named
    assert registry.load_inline(urdf, base_frame="root") is named
    # a base below the root: the tree below it
    assert urdf_screen.screen_urdf(chain(3), None, "l0").tip_frame == "l3"


def test_tool0_is_the_default_tip_among_equally_deep_links() -> None:
    ends = [joint("j", "base", "l1"), joint("e", "l1", "ee_link", "fixed", xyz="0 0.1 0")]
    links = ["base", "l1", "ee_link"]
    with pytest.raises(InvalidURDF) as err:
        urdf_screen.screen_urdf(
            robot(*ends, joint("t", "l1", "tool1", "fixed"), links=[*links, "tool1"]), None, None
        )
    assert err.value.field == ("robot", "tip_frame")
    assert err.value.extra["candidates"] == ["ee_link", "tool1"]
    assert "ee_link, tool1" in err.value.detail and "name tip_frame" in err.value.detail
    urdf = robot(*ends, joint("t", "l1", "tool0", "fixed"), links=[*links, "tool0"])
    assert urdf_screen.screen_urdf(urdf, None, None).tip_frame == "tool0"


def test_a_tree_branching_through_movable_joints_has_no_default_tip() -> None:
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(OFFSET_BASE_URDF)  # fingers fa and fb are prismatic joints off l4
    assert err.value.field == ("robot", "tip_frame")
    assert err.value.extra["candidates"] == ["tool", "fa", "fb"]
    assert "branches through movable joints" in err.value.detail
    assert "tool, fa, fb" in err.value.detail
    # two arms on one base
    arms = robot(
        joint("a", "base", "left"), joint("b", "base", "right"), links=["base", "left", "right"]
    )
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(arms)
    assert err.value.extra["candidates"] == ["left", "right"]
    # nothing movable below the base
    fixed = robot(joint("f", "base", "plate", "fixed"), links=["base", "plate"])
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(fixed)
    assert err.value.field == ("robot", "tip_frame") and "no movable joint" in err.value.detail
    # the base is checked first: a movable joint above it is that error, not the tip's
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(chain(3), None, "l1")
    assert err.value.field == ("robot", "base_frame")


def test_many_candidates_are_listed_in_full_and_named_in_part() -> None:
    parts = [joint(f"j{k}", "base", f"leg{k}") for k in range(20)]
    with pytest.raises(InvalidURDF) as err:
        registry.load_inline(robot(*parts, links=["base"] + [f"leg{k}" for k in range(20)]))
    assert len(err.value.extra["candidates"]) == 20
    assert "20 leaf links" in err.value.detail and err.value.detail.endswith(", ...")
    assert "leg15" in err.value.detail and "leg16" not in err.value.detail
