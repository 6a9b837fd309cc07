"""Inline URDF boxes and cylinders are checked as boxes and cylinders: distances, the motion bound and
the continuous check against coal computed independently (shapes built from the URDF's numbers,
placed by pinocchio's frame poses), never through our engine."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from robots import registry
from robots.collision import CollisionChecker, Obstacle, robot_collision
from tests.robots.inline_urdfs import joint, robot

# link -> (coal shape, T_link_shape): the URDF's own numbers, written out a second time
BOX_L1 = (0.5, 0.06, 0.08)
CYL_L2 = (0.04, 0.3)
URDF = robot(
    joint("j1", "base", "l1", xyz="0 0 0.1", axis="0 0 1"),
    joint("j2", "l1", "l2", xyz="0.5 0 0", axis="0 1 0"),
    joint("j3", "l2", "l3", xyz="0.3 0 0", axis="1 0 0"),
    joint("t", "l3", "tip", "fixed", xyz="0.1 0 0"),
    links=["base", "l1", "l2", "l3", "tip"],
)
URDF = (
    URDF.replace(
        '<link name="base"/>',
        '<link name="base"><collision><geometry><box size="0.3 0.3 0.05"/></geometry>'
        "</collision></link>",
    )
    .replace(
        '<link name="l1"/>',
        '<link name="l1"><collision><origin xyz="0.25 0 0" rpy="0.2 0 0"/><geometry>'
        f'<box size="{BOX_L1[0]} {BOX_L1[1]} {BOX_L1[2]}"/></geometry></collision></link>',
    )
    .replace(
        '<link name="l2"/>',
        '<link name="l2"><collision><origin xyz="0.15 0 0" rpy="0 1.5707963267948966 0"/>'
        f'<geometry><cylinder radius="{CYL_L2[0]}" length="{CYL_L2[1]}"/></geometry>'
        "</collision></link>",
    )
    .replace(
        '<link name="l3"/>',
        '<link name="l3"><collision><origin xyz="0.05 0 0"/><geometry><box size="0.1 0.05 0.05"/>'
        '</geometry></collision><collision><origin xyz="0.1 0 0"/><geometry><sphere radius="0.03"/>'
        "</geometry></collision></link>",
    )
)


def T(p, rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    M = np.eye(4)
    M[:3, :3] = pin.rpy.rpyToMatrix(*rpy)
    M[:3, 3] = p
    return M


REFERENCE = {  # link -> [(coal shape, T_link_shape)], from the URDF text above
    "base": [(coal.Box(0.3, 0.3, 0.05), T([0, 0, 0]))],
    "l1": [(coal.Box(*BOX_L1), T([0.25, 0, 0], (0.2, 0, 0)))],
    "l2": [(coal.Cylinder(*CYL_L2), T([0.15, 0, 0], (0, np.pi / 2, 0)))],
    "l3": [(coal.Box(0.1, 0.05, 0.05), T([0.05, 0, 0])), (coal.Sphere(0.03), T([0.1, 0, 0]))],
}


def coal_distance(s1, T1: np.ndarray, s2, T2: np.ndarray) -> float:
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    req.gjk_tolerance = 1e-10
    t1 = coal.Transform3s(T1[:3, :3], T1[:3, 3])
    t2 = coal.Transform3s(T2[:3, :3], T2[:3, 3])
    return float(coal.distance(s1, t1, s2, t2, req, res))


def obstacle_shape(o: Obstacle):
    return {
        "box": lambda: coal.Box(*o.size),
        "sphere": lambda: coal.Sphere(o.radius),
        "cylinder": lambda: coal.Cylinder(o.radius, o.length),
        "capsule": lambda: coal.Capsule(o.radius, o.length),
    }[o.shape]()


def reference_min(arm, q: np.ndarray, obstacles: list[Obstacle], link_pairs=()) -> dict:
    """Smallest coal distance per (link, obstacle) and per (link, link) pair at ``q``."""
    placed = {
        link: [(s, arm.frame_pose(q, link) @ M) for s, M in shapes]
        for link, shapes in REFERENCE.items()
        if link in arm.frame_names()
    }
    out = {}
    for link, shapes in placed.items():
        for o in obstacles:
            if link == "base":
                continue  # the base stands on its mount: never checked against obstacles
            if o.shape == "halfspace":
                hs = coal.Halfspace(np.array(o.normal), o.offset)
                d = min(coal_distance(s, M, hs, np.eye(4)) for s, M in shapes)
            else:
                d = min(
                    coal_distance(s, M, obstacle_shape(o), o.T_base_obstacle) for s, M in shapes
                )
            out[(link, o.name)] = d
    for a, b in link_pairs:
        out[(a, b)] = min(
            coal_distance(s1, M1, s2, M2) for s1, M1 in placed[a] for s2, M2 in placed[b]
        )
    return out


def every_shape() -> list[Obstacle]:
    return [
        Obstacle("box", "box", size=(0.2, 0.3, 0.1), T_base_obstacle=T([0.55, 0.35, 0.2], (0.3, 0.2, 0.1))),
        Obstacle("ball", "sphere", radius=0.08, T_base_obstacle=T([0.4, -0.3, 0.25])),
        Obstacle("can", "cylinder", radius=0.05, length=0.3, T_base_obstacle=T([-0.4, 0.3, 0.2], (0.5, 0, 0))),
        Obstacle("rod", "capsule", radius=0.04, length=0.3, T_base_obstacle=T([0.2, 0.5, 0.1], (0, 0.7, 0))),
        Obstacle("floor", "halfspace", normal=(0.0, 0.0, 1.0), offset=-0.05),
    ]  # fmt: skip


@pytest.fixture(scope="module")
def arm():
    return registry.load_inline(URDF, "tip", "base")


def test_box_and_cylinder_links_are_exact_shapes(arm) -> None:
    geometry = robot_collision(arm, URDF)
    assert geometry.links == ("base", "l1", "l2", "l3", "l3")
    assert geometry.kind.tolist() == [1, 1, 2, 1, 0]  # box, box, cylinder, box, sphere


def test_a_box_link_next_to_a_box_obstacle_reads_its_true_distance(arm) -> None:
    """A box link 1 cm from a box obstacle (enclosing capsules read it as -0.356 m, a false
    collision), and one far away (a capsule read 3.929 m of 7.379 m): exact now, against coal."""
    q = np.zeros(3)
    T_l1 = arm.frame_pose(q, "l1") @ REFERENCE["l1"][0][1]  # the box's centre and axes
    near = T_l1 @ T([0.0, 0.0, BOX_L1[2] / 2 + 0.01 + 0.05])  # 1 cm above its top face
    far = T_l1 @ T([7.0, 2.0, 1.0], (0.4, 0.1, 0.9))
    obstacles = [
        Obstacle("plate", "box", size=(0.4, 0.3, 0.1), T_base_obstacle=near),
        Obstacle("far", "box", size=(0.5, 0.5, 0.5), T_base_obstacle=far),
    ]
    check = CollisionChecker(arm, robot_collision(arm, URDF), obstacles, self_collision=False)
    D = dict(zip(check.pair_names, check.distances(q[None])[0], strict=True))
    ref = reference_min(arm, q, obstacles)
    assert D[("l1", "plate")] == pytest.approx(0.01, abs=1e-6)
    assert D[("l1", "plate")] == pytest.approx(ref[("l1", "plate")], abs=1e-6)
    assert D[("l1", "far")] == pytest.approx(ref[("l1", "far")], abs=1e-6)
    assert D[("l1", "far")] > 6.5


def test_distances_equal_coal_for_every_pair_kind(arm) -> None:
    """Every robot shape (box, cylinder, sphere) against every obstacle shape and every other link's
    shapes (no allowed pairs): closed forms and coal calls equal coal computed independently."""
    obstacles = every_shape()
    check = CollisionChecker(arm, robot_collision(arm, URDF), obstacles)
    links = sorted({a for a, _ in check.pair_names} | {"base"})
    link_pairs = [(a, b) for a in links for b in links if a < b]
    rng = np.random.default_rng(11)
    worst, inside = 0.0, 0
    for q in rng.uniform(-3, 3, (60, 3)):
        D = check.distances(q[None])[0]
        ref = reference_min(arm, q, obstacles, link_pairs)
        mine: dict[tuple[str, str], float] = {}
        for (a, b), d in zip(check.pair_names, D, strict=True):
            key = (a, b) if (a, b) in ref else (b, a)
            mine[key] = min(mine.get(key, np.inf), d)
        for key, d in mine.items():
            if ref[key] > 0 or d > 0:
                worst = max(worst, abs(ref[key] - d))
            else:
                inside += 1  # both in penetration: the depth is not a signed distance for GJK
    assert worst < 1e-6, worst
    assert inside > 0  # the sweep reaches contacts too


def test_motion_bound_holds_for_boxes_and_cylinders(arm) -> None:
    """Over linear joint steps no pair's distance changes faster than ``motion_weights @ |dq|``
    (the levers reach the farthest box corner and cylinder rim)."""
    check = CollisionChecker(arm, robot_collision(arm, URDF), every_shape())
    rng = np.random.default_rng(12)
    s = np.linspace(0, 1, 201)
    for _ in range(30):
        q0, dq = rng.uniform(-3, 3, 3), rng.normal(scale=0.5, size=3)
        D = check.distances(q0 + s[:, None] * dq)
        change = np.abs(np.diff(D, axis=0)).sum(axis=0)  # total variation along the step
        assert np.all(change <= np.abs(dq) @ check.motion_weights.T + 1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_continuous_check_on_exact_shapes_against_a_coal_sweep(arm, seed: int) -> None:
    """min_clearance is a lower bound of coal's minimum over a fine sweep of the motion (joints
    linear between the returned points), within 1e-4 m of it; a contact exactly when that sweep
    comes within the clearance."""
    rng = np.random.default_rng(20 + seed)
    obstacles = every_shape()[:4]
    check = CollisionChecker(arm, robot_collision(arm, URDF), obstacles, clearance=0.02,
                             self_collision=False)  # fmt: skip
    while True:
        qs = np.cumsum(rng.normal(scale=0.15, size=(9, 3)), axis=0) + rng.uniform(-2, 2, 3)
        if (check.distances(qs[[0, -1]]) >= 0.02).all():
            break
    result = check.check_path(np.linspace(0, 2, 9), qs)
    f = np.linspace(0, 1, 201)[:-1]
    steps = np.diff(qs, axis=0)
    dense = np.vstack([(qs[:-1, None] + f[:, None] * steps[:, None]).reshape(-1, 3), qs[-1:]])
    sweep = min(min(reference_min(arm, q, obstacles).values()) for q in dense)
    if result.contact is None:
        assert sweep >= 0.02 - 1e-9
        assert sweep - 1e-4 <= result.min_clearance <= sweep + 1e-9
    else:
        assert sweep < 0.02 + 1e-6


def test_geometry_model_holds_the_exact_shapes(arm) -> None:
    """``geometry_model()``: coal boxes and cylinders (not capsules), one collision pair per checked
    pair, and pinocchio's ``computeDistances`` on it gives ``distances()``."""
    check = CollisionChecker(arm, robot_collision(arm, URDF), every_shape())
    gm, names = check.geometry_model()
    kinds = {type(o.geometry).__name__ for o in gm.geometryObjects}
    assert {"Box", "Cylinder", "Sphere"} <= kinds and "Capsule" in kinds  # the rod obstacle
    assert sorted(names) == sorted(check.pair_names)
    q = np.array([0.3, -0.4, 0.8])
    data, gdata = pin.Data(arm.model), pin.GeometryData(gm)
    pin.computeDistances(arm.model, data, gm, gdata, q)
    ours: dict[tuple[str, str], float] = {}
    for name, d in zip(check.pair_names, check.distances(q[None])[0], strict=True):
        ours[name] = min(ours.get(name, np.inf), d)
    theirs: dict[tuple[str, str], float] = {}
    for name, res in zip(names, gdata.distanceResults, strict=True):
        theirs[name] = min(theirs.get(name, np.inf), res.min_distance)
    assert ours.keys() == theirs.keys()
    for name, d in theirs.items():
        if d > 0:
            assert ours[name] == pytest.approx(d, abs=2e-6), name
