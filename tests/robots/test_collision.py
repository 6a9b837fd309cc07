"""Collision geometry and the continuous check, against independent references: coal (pinocchio's
GeometryModel), brute-force sampling, pinocchio frame placements and closed-form distances."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import robots.collision.continuous as continuous
from core.clearance import Clearance, velocity_damper_rows
from core.errors import TooLarge
from robots import registry
from robots.collision import (
    CollisionChecker,
    Obstacle,
    allowed_self_pairs,
    damper_inputs,
    robot_collision,
    robot_setup,
)
from robots.geometry import ROBOT_GEOMETRY, Box, Capsule, Cylinder
from robots.geometry.distance import segment_segment
from robots.geometry.urdf import enclosing_capsule, shapes_from_urdf

ROBOTS = ["planar_2r", "puma560", "ur5", "panda"]


def T(p, rpy=(0.3, 0.2, 0.1)) -> np.ndarray:
    M = np.eye(4)
    M[:3, :3] = pin.rpy.rpyToMatrix(*rpy)
    M[:3, 3] = p
    return M


def every_shape() -> list[Obstacle]:
    return [
        Obstacle("box", "box", size=(0.3, 0.2, 0.1), T_base_obstacle=T([0.4, 0.2, 0.3])),
        Obstacle("ball", "sphere", radius=0.1, T_base_obstacle=T([0.3, -0.3, 0.5])),
        Obstacle("can", "cylinder", radius=0.05, length=0.4, T_base_obstacle=T([-0.3, 0.3, 0.4])),
        Obstacle("rod", "capsule", radius=0.05, length=0.4, T_base_obstacle=T([-0.3, -0.3, 0.4])),
        Obstacle("floor", "halfspace", normal=(0.0, 0.0, 1.0), offset=-0.05),
    ]


def capsule_world(robot, q: np.ndarray, link: str) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """The shipped capsules of ``link`` in the base frame, placed with pinocchio's frame pose."""
    T_bl = robot.frame_pose(q, link)
    out = []
    for c in ROBOT_GEOMETRY[robot.name].capsules:
        if c.link == link:
            a = T_bl[:3, :3] @ np.array(c.a) + T_bl[:3, 3]
            b = T_bl[:3, :3] @ np.array(c.b) + T_bl[:3, 3]
            out.append((a, b, c.radius))
    return out


def point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = 0.0 if d @ d == 0 else float(np.clip((p - a) @ d / (d @ d), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * d)))


@pytest.mark.parametrize("name", ROBOTS)
def test_capsules_sit_on_links_of_the_model(name: str) -> None:
    robot = registry.get(name)
    g = robot_collision(robot)
    assert len(g.links) == len(ROBOT_GEOMETRY[name].capsules)
    assert set(g.links) <= set(robot.frame_names())
    assert np.all(g.radius > 0)


@pytest.mark.parametrize("name", ROBOTS)
def test_allowed_pairs_hold_adjacent_links_and_only_pairs_that_never_touch(name: str) -> None:
    robot = registry.get(name)
    geometry, allowed = robot_setup(robot)
    model = robot.model
    joint_of = {n: int(j) for n, j in zip(geometry.links, geometry.joints, strict=True)}
    for a in set(geometry.links):
        for b in set(geometry.links) - {a}:
            ja, jb = joint_of[a], joint_of[b]
            if model.parents[ja] == jb or model.parents[jb] == ja:
                assert frozenset((a, b)) in allowed
    # a fresh sample (other seed): every allowed non-adjacent pair is clear or always in contact
    unchecked = CollisionChecker(robot, geometry)
    qs = np.random.default_rng(7).uniform(
        np.maximum(robot.position_limits[:, 0], -np.pi),
        np.minimum(robot.position_limits[:, 1], np.pi),
        (500, robot.dof),
    )
    D = unchecked.distances(qs)
    checked = CollisionChecker(robot, geometry, allowed_self=allowed)
    assert set(checked.pair_names) <= set(unchecked.pair_names)
    assert isinstance(checked, Clearance)
    if name == "panda":
        assert checked.n_pairs > 0  # the Panda can hit itself
    # capsule pairs of an allowed, non-adjacent link pair: never touch (sampling may miss < 1%) or
    # always touch (built into the arm)
    by_links: dict[frozenset[str], np.ndarray] = {}
    for p, name in enumerate(unchecked.pair_names):
        key = frozenset(name)
        by_links[key] = by_links.get(key, np.zeros(len(qs), dtype=bool)) | (D[:, p] < 0)
    for key, touch in by_links.items():
        a, b = sorted(key)
        ja, jb = joint_of[a], joint_of[b]
        adjacent = ja == jb or model.parents[ja] == jb or model.parents[jb] == ja
        if key in allowed and not adjacent:
            assert touch.mean() < 0.01 or touch.all(), (a, b, touch.mean())
        if key not in allowed:
            assert (a, b) in checked.pair_names or (b, a) in checked.pair_names


def test_numpy_distances_equal_coal_for_every_shape() -> None:
    robot = registry.get("ur5")
    geometry, allowed = robot_setup(robot)
    check = CollisionChecker(robot, geometry, every_shape(), allowed_self=allowed)
    gm, names = check.geometry_model()
    assert sorted(names) == sorted(check.pair_names)
    _, pairs = check.coal_geometry()
    qs = np.random.default_rng(1).uniform(-np.pi, np.pi, (150, 6))
    D = check.distances(qs)
    worst = 0.0
    for n, q in enumerate(qs):
        data, gdata = pin.Data(robot.model), pin.GeometryData(gm)
        pin.computeDistances(robot.model, data, gm, gdata, q)
        index = {(cp.first, cp.second): k for k, cp in enumerate(gm.collisionPairs)}
        dc = np.array([gdata.distanceResults[index[p]].min_distance for p in pairs])
        outside = (dc > 0) | (D[n] > 0)  # coal's penetration depth is not a signed distance for GJK
        worst = max(worst, float(np.abs(dc - D[n])[outside].max()))
    assert worst < 1e-5  # coal's GJK tolerance on boxes and cylinders; closed forms below are 1e-9


def test_closed_form_distances_equal_pinocchio_frame_geometry() -> None:
    robot = registry.get("ur5")
    geometry, _ = robot_setup(robot)
    c, R = np.array([0.3, -0.3, 0.5]), 0.1
    obstacles = [
        Obstacle("ball", "sphere", radius=R, T_base_obstacle=T(c)),
        Obstacle("floor", "halfspace", normal=(0.0, 0.0, 1.0), offset=-0.05),
    ]
    check = CollisionChecker(robot, geometry, obstacles, self_collision=False)
    for q in np.random.default_rng(2).uniform(-np.pi, np.pi, (40, 6)):
        D = check.distances(q[None])[0]
        for p, (link, obstacle) in enumerate(check.pair_names):
            caps = capsule_world(robot, q, link)
            k = [i for i, n in enumerate(check.pair_names) if n[0] == link and n[1] == obstacle]
            if obstacle == "ball":
                ref = [point_segment(c, a, b) - r - R for a, b, r in caps]
            else:
                ref = [min(a[2], b[2]) + 0.05 - r for a, b, r in caps]
            assert sorted(D[k]) == pytest.approx(sorted(ref), abs=1e-9), (link, obstacle)
            del p


def test_segment_segment_against_brute_force() -> None:
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, 401)
    for _ in range(60):
        a1, b1, a2, b2 = rng.normal(size=(4, 3))
        if rng.random() < 0.2:
            b2 = a2.copy()  # a point
        d, p1, p2 = segment_segment(a1, b1, a2, b2)
        P = a1 + t[:, None] * (b1 - a1)
        Q = a2 + t[:, None] * (b2 - a2)
        brute = np.linalg.norm(P[:, None] - Q[None], axis=2).min()
        assert d <= brute + 1e-12
        assert d == pytest.approx(brute, abs=1e-2)
        assert np.linalg.norm(p1 - p2) == pytest.approx(float(d), abs=1e-12)


@pytest.mark.parametrize("name", ["ur5", "panda", "puma560"])
def test_motion_bound_holds_for_every_pair(name: str) -> None:
    """Over a linear joint step, no pair's distance changes faster than the bound behind the check."""
    robot = registry.get(name)
    geometry, allowed = robot_setup(robot)
    check = CollisionChecker(robot, geometry, every_shape(), allowed_self=allowed)
    rng = np.random.default_rng(4)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    for _ in range(20):
        q0 = rng.uniform(np.maximum(lo, -3), np.minimum(hi, 3))
        dq = rng.normal(scale=0.3, size=robot.dof)
        s = np.linspace(0, 1, 201)
        D = check.distances(q0 + s[:, None] * dq)
        bound = np.abs(dq) @ check.motion_weights.T
        change = np.abs(D - D[0]).max(axis=0)
        assert np.all(change <= bound + 1e-9)


def test_continuous_check_catches_an_obstacle_between_two_clear_points() -> None:
    """Both ends clear, the middle of the swing passes through a ball: a check at the returned points
    alone sees nothing; the continuous check finds the first contact, at the time a dense sweep finds."""
    robot = registry.get("ur5")
    geometry, allowed = robot_setup(robot)
    q0 = robot.home.copy()
    q1 = q0.copy()
    q1[0] += 2.0  # swing the shoulder pan by 2 rad
    tool_mid = robot.fk((q0 + q1) / 2)[:3, 3]
    ball = Obstacle("ball", "sphere", radius=0.05, T_base_obstacle=T(tool_mid, (0, 0, 0)))
    check = CollisionChecker(robot, geometry, [ball], allowed_self=allowed)
    times, qs = np.array([0.0, 2.0]), np.array([q0, q1])
    assert np.all(check.distances(qs) >= 0)  # a point check is blind
    result = check.check_path(times, qs)
    assert result.contact is not None
    s = np.linspace(0, 1, 20_001)
    d = check.distances(q0 + s[:, None] * (q1 - q0))
    first = s[np.argmax((d < 0).any(axis=1))] * 2.0
    assert result.contact.time == pytest.approx(first, abs=2e-4)
    assert result.contact.links[1] == "ball"
    assert result.contact.distance < 0


def test_clear_motion_reports_min_clearance_of_an_independent_computation() -> None:
    robot = registry.get("ur5")
    geometry, _ = robot_setup(robot)
    c, R = np.array([0.45, 0.3, 0.2]), 0.08
    ball = Obstacle("ball", "sphere", radius=R, T_base_obstacle=T(c))
    check = CollisionChecker(robot, geometry, [ball], self_collision=False)
    q0 = robot.home.copy()
    qs = q0 + np.linspace(0, 1, 301)[:, None] * np.array([0.6, 0.2, -0.2, 0.1, 0.3, 0.0])
    result = check.check_path(np.linspace(0, 3, 301), qs)
    assert result.contact is None
    dense = q0 + np.linspace(0, 1, 3001)[:, None] * np.array([0.6, 0.2, -0.2, 0.1, 0.3, 0.0])
    ref = min(
        point_segment(c, a, b) - r - R
        for q in dense
        for link in set(geometry.links) - {"base_link"}
        for a, b, r in capsule_world(robot, q, link)
    )
    # certified: a lower bound of the motion's minimum (between the points too), within 1e-4 m
    assert ref - 1e-4 <= result.min_clearance <= ref + 1e-12
    assert result.closest is not None and result.closest[0][1] == "ball"


def test_panda_self_collision_is_found() -> None:
    """Folding joint 4 and 6 drives the hand flange into the upper arm; coal agrees."""
    robot = registry.get("panda")
    geometry, allowed = robot_setup(robot)
    check = CollisionChecker(robot, geometry, allowed_self=allowed)
    rng = np.random.default_rng(5)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    qs = rng.uniform(lo, hi, (3000, 7))
    D = check.distances(qs)
    hits = np.flatnonzero((D < -0.01).any(axis=1))
    assert len(hits) > 0
    q_bad = qs[hits[0]]
    p = int(np.argmin(D[hits[0]]))
    gm, names = check.geometry_model()
    data, gdata = pin.Data(robot.model), pin.GeometryData(gm)
    pin.computeCollisions(robot.model, data, gm, gdata, q_bad, False)
    colliding = {names[k] for k, r in enumerate(gdata.collisionResults) if r.isCollision()}
    assert check.pair_names[p] in colliding
    # a joint move from home into it: the continuous check stops before it
    result = check.check_path(np.array([0.0, 1.0]), np.array([robot.home, q_bad]))
    assert result.contact is not None and result.contact.time <= 1.0
    assert all(name.startswith("panda_link") for name in result.contact.links)


def test_inline_urdf_primitives_are_exact_shapes_and_meshes_are_listed() -> None:
    """Spheres, boxes and cylinders stay what they are (exact); their enclosing capsules (used only
    for cheap lower bounds) contain them; mesh-only links are listed."""
    urdf = """<robot name="r">
      <link name="base"><collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision></link>
      <link name="l1"><collision><origin xyz="0.25 0 0"/><geometry><cylinder radius="0.05"
        length="0.5"/></geometry></collision></link>
      <link name="l2"><collision><geometry><sphere radius="0.04"/></geometry></collision>
        <collision><geometry><mesh filename="x.stl"/></geometry></collision></link>
      <link name="tip"><collision><geometry><mesh filename="y.stl"/></geometry></collision></link>
    </robot>"""
    shapes, mesh_only = shapes_from_urdf(urdf)
    assert mesh_only == ["tip"]
    by_link = {s.link: s for s in shapes}
    box, cyl, ball = by_link["base"], by_link["l1"], by_link["l2"]
    assert isinstance(box, Box) and box.size == (0.2, 0.2, 0.1)
    assert isinstance(cyl, Cylinder) and (cyl.radius, cyl.length) == (0.05, 0.5)
    np.testing.assert_allclose(cyl.T_link_shape[:3, 3], [0.25, 0.0, 0.0])
    assert isinstance(ball, Capsule) and ball.radius == 0.04 and ball.a == ball.b
    rng = np.random.default_rng(6)
    for shape, half, kind in ((box, np.array([0.1, 0.1, 0.05]), "box"), (cyl, None, "cyl")):
        if kind == "box":
            pts = rng.choice([-1.0, 1.0], (2000, 3)) * half  # the corners: the farthest points
        else:
            u = rng.uniform(0, 2 * np.pi, 2000)  # the rim and the side surface, ends included
            z = np.where(rng.random(2000) < 0.5, rng.choice([-0.25, 0.25], 2000), 0.0)
            z = np.where(z == 0, rng.uniform(-0.25, 0.25, 2000), z)
            pts = np.c_[0.25 + 0.05 * np.cos(u), 0.05 * np.sin(u), z]
        a, b, radius = enclosing_capsule(shape)
        d = np.array([point_segment(p, a, b) for p in pts])
        assert np.all(d <= radius + 1e-12), shape.link


def test_velocity_damper_rows() -> None:
    d = np.array([0.05, 0.3, 0.02])
    n = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    Jp = np.random.default_rng(8).normal(size=(3, 3, 4))
    rows = velocity_damper_rows(d, n, Jp, dt=0.01, d_safe=0.01, d_influence=0.1, xi=0.5)
    assert rows.active.tolist() == [True, False, True]
    assert rows.G == pytest.approx(-np.stack([n[0] @ Jp[0], n[2] @ Jp[2]]), abs=1e-15)
    assert rows.h == pytest.approx(0.5 * (d[[0, 2]] - 0.01) / 0.01, abs=1e-12)
    # a velocity on the boundary of the row closes exactly the allowed share of the margin
    qd = np.linalg.pinv(rows.G[:1]) @ rows.h[:1]
    approach = -(n[0] @ Jp[0] @ qd) * 0.01
    assert approach == pytest.approx(0.5 * (0.05 - 0.01), abs=1e-12)
    with pytest.raises(ValueError):
        velocity_damper_rows(d, n, Jp, dt=0.01, d_safe=0.1, d_influence=0.1)


def test_allowed_self_pairs_is_deterministic() -> None:
    robot = registry.get("panda")
    geometry = robot_collision(robot)
    assert allowed_self_pairs(robot, geometry, samples=500) == allowed_self_pairs(
        robot, geometry, samples=500
    )


@pytest.mark.parametrize("seed", range(8))
def test_branch_and_bound_check_equals_exhaustive_references(seed: int) -> None:
    """Random work cells of every shape and random joint paths: min_clearance is a lower bound of the
    minimum over a dense sweep of the motion, within 1e-4 m of it (it was the minimum over the
    returned points only, above the motion's true minimum), and the first contact equals the first
    crossing of a dense sweep (to 1e-3 of the duration)."""
    rng = np.random.default_rng(100 + seed)
    robot = registry.get("ur5" if seed % 2 else "panda")
    geometry, allowed = robot_setup(robot)
    shapes = ["box", "sphere", "cylinder", "capsule", "box", "cylinder"]
    obstacles = [
        Obstacle(
            f"o{k}",
            sh,
            size=tuple(rng.uniform(0.05, 0.3, 3)),
            radius=float(rng.uniform(0.03, 0.1)),
            length=float(rng.uniform(0.05, 0.4)),
            T_base_obstacle=T(
                rng.uniform([-0.8, -0.8, 0.1], [0.8, 0.8, 0.9]), rng.uniform(-3, 3, 3)
            ),
        )
        for k, sh in enumerate(shapes)
    ] + [Obstacle("floor", "halfspace", normal=(0.0, 0.0, 1.0), offset=-0.2)]
    check = CollisionChecker(robot, geometry, obstacles, clearance=0.01, allowed_self=allowed)
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]

    def clear_configuration(near: np.ndarray | None) -> np.ndarray:
        while True:  # both ends clear: every contact found lies inside the motion
            q = (
                rng.uniform(np.maximum(lo, -2), np.minimum(hi, 2))
                if near is None
                else np.clip(near + rng.normal(scale=1.5, size=robot.dof), lo, hi)
            )
            if (check.distances(q[None])[0] >= check.threshold).all():
                return q

    q0 = clear_configuration(None)
    q1 = clear_configuration(q0)
    n = 301
    s = np.linspace(0, 1, n)
    qs = q0 + s[:, None] * (q1 - q0)
    times = 3.0 * s
    result = check.check_path(times, qs)
    D = check.distances(qs)
    bad = (D < check.threshold).any(axis=1)
    dense = np.linspace(0, 1, 6_001)
    Dd = check.distances(q0 + dense[:, None] * (q1 - q0))
    if result.contact is None:
        assert not bad.any() and (Dd >= check.threshold).all()
        assert Dd.min() - 1e-4 <= result.min_clearance <= Dd.min() + 1e-12
        return
    first = 3.0 * dense[int(np.argmax((Dd < check.threshold).any(axis=1)))]
    assert result.contact.time == pytest.approx(first, abs=3e-3), (seed, result.contact)
    if bad.any():
        assert result.contact.time <= times[int(np.argmax(bad))] + 1e-12


def test_damper_inputs_predict_the_distance_rate() -> None:
    """n . (J_p dq) equals the finite-difference change of the pair's distance (obstacle and self
    pairs), so the velocity-damper rows built from them constrain the right quantity."""
    robot = registry.get("panda")
    geometry, allowed = robot_setup(robot)
    # a generic configuration: at home some capsules are parallel (closest points not unique, the
    # distance not differentiable)
    q = robot.home + np.random.default_rng(10).normal(scale=0.1, size=7)
    ball_at = robot.frame_pose(q, "panda_link5")[:3, 3] + [0.0, 0.2, 0.0]
    ball = Obstacle("ball", "sphere", radius=0.05, T_base_obstacle=T(ball_at))
    check = CollisionChecker(robot, geometry, [ball], allowed_self=allowed)
    inputs = damper_inputs(check, q, d_influence=0.5)
    assert len(inputs.pairs) > 0
    assert any(check.pair_names[p][1] == "ball" for p in inputs.pairs)
    d0 = check.distances(q[None])[0]
    assert inputs.distances == pytest.approx(d0[inputs.pairs], abs=1e-6)
    rng = np.random.default_rng(9)
    for _ in range(5):
        dq = rng.normal(size=robot.dof)
        h = 1e-6
        rate = (check.distances((q + h * dq)[None])[0] - d0)[inputs.pairs] / h
        pred = np.einsum("pi,pij,j->p", inputs.normals, inputs.point_jacobians, dq)
        assert pred == pytest.approx(rate, abs=1e-4)
    rows = velocity_damper_rows(
        inputs.distances, inputs.normals, inputs.point_jacobians,
        dt=0.01, d_safe=0.01, d_influence=0.5,
    )  # fmt: skip
    assert rows.G.shape == (len(inputs.pairs), robot.dof)
    pairs, dist, normals, jacobians = check.close_pairs(q, 0.5)  # the Clearance Protocol's form
    assert np.array_equal(pairs, inputs.pairs) and np.allclose(jacobians, inputs.point_jacobians)
    assert np.allclose(dist, inputs.distances) and np.allclose(normals, inputs.normals)


def test_a_check_over_the_size_bound_is_too_large(monkeypatch) -> None:
    robot = registry.get("ur5")
    geometry, allowed = robot_setup(robot)
    check = CollisionChecker(robot, geometry, every_shape(), allowed_self=allowed)
    qs = np.linspace(robot.home, robot.home + 0.1, 1000)
    keys = (1000 - 1) // continuous.KEY_STEP + 2  # every KEY_STEP-th point and the last
    monkeypatch.setattr(continuous, "MAX_KEY_ENTRIES", keys * check.n_pairs - 1)
    with pytest.raises(TooLarge) as info:
        check.check_path(np.linspace(0, 1, 1000), qs)
    assert info.value.field == ("environment",)
