"""CIRC on single Cartesian tasks: every method follows the circle arc (``path: circ``).

The circle is checked here independently of ``core.path.arc``: the centre and radius are the
test's own numbers, the tool positions come from the robot's forward kinematics (``fk_many``) of the
returned joints and of dense linear interpolations between them, and the orientation reference is
scipy's ``Slerp`` at the angle the tool point has turned about the centre.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from core.cartesian.path_rates import path_rates
from core.cartesian.plan import plan
from core.cartesian.rate.control import GOAL_FRACTION
from core.cartesian.task import CartesianTask, PathSpec
from core.cartesian.walk import walk_line
from core.errors import InputError
from core.kinematics import task_rows
from robots import registry

UR5 = registry.get("ur5")
UR5_HOME = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
RADIUS = 0.08
SWEEP = 2.0 * math.pi / 3  # 120 degrees about +z
TURN = 0.3  # [rad] the tool also turns about its own x axis on the way
METHODS = ("sampled", "bounded_deviation", "bounded_deviation_nlp", "resolved_rate",
           "resolved_rate_dls")  # fmt: skip
EXACT_END_METHODS = ("sampled", "bounded_deviation", "bounded_deviation_nlp")


def _rz(a: float) -> np.ndarray:
    return Rotation.from_rotvec([0.0, 0.0, a]).as_matrix()


def circle_case(sweep: float = SWEEP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start pose, goal pose and centre: the tool point turns ``sweep`` about +z around a centre
    ``RADIUS`` beside the start, while the tool turns ``TURN`` about its x axis."""
    T0 = UR5.fk(UR5_HOME)
    c = T0[:3, 3] + np.array([0.0, RADIUS, 0.0])
    Tg = T0.copy()
    Tg[:3, 3] = c + _rz(sweep) @ (T0[:3, 3] - c)
    Tg[:3, :3] = T0[:3, :3] @ Rotation.from_rotvec([TURN, 0.0, 0.0]).as_matrix()
    return T0, Tg, c


def arc_errors(T: np.ndarray, T0: np.ndarray, Tg: np.ndarray, c: np.ndarray, sweep: float):
    """Radius error, distance from the circle's plane, and orientation error [rad] against the
    slerp at the angle turned about the centre (the test's own circle)."""
    d = T[:, :3, 3] - c
    radius = np.linalg.norm(d[:, :2], axis=1) - RADIUS
    height = d[:, 2]
    a0 = math.atan2(*(T0[:3, 3] - c)[1::-1])
    turned = np.mod(np.arctan2(d[:, 1], d[:, 0]) - a0 + 1e-9, 2 * math.pi) - 1e-9
    s = np.clip(turned / sweep, 0.0, 1.0)
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], Tg[:3, :3]])))
    orientation = (slerp(s).inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()
    return radius, height, orientation, s


def dense(positions: np.ndarray, per: int = 16) -> np.ndarray:
    """``positions`` (N, dof) with ``per - 1`` linear interpolants inside every interval."""
    w = np.linspace(0.0, 1.0, per, endpoint=False)[:, None, None]
    inner = (1.0 - w) * positions[:-1][None] + w * positions[1:][None]
    return np.vstack([inner.transpose(1, 0, 2).reshape(-1, positions.shape[1]), positions[-1:]])


@pytest.mark.parametrize("method", METHODS)
def test_every_method_follows_the_circle(method: str) -> None:
    T0, Tg, c = circle_case()
    tol_p, tol_o = 1e-3, 1e-2
    task = CartesianTask(
        robot=UR5,
        q_start=UR5_HOME,
        T_goal=Tg,
        path=PathSpec("circ", center=c),
        position_tolerance=tol_p,
        orientation_tolerance=tol_o,
        sample_period=0.02,
    )
    result = plan(task, method)
    traj = result.trajectory
    radius, height, orientation, s = arc_errors(
        UR5.fk_many(dense(traj.positions)), T0, Tg, c, SWEEP
    )
    assert np.hypot(radius, height).max() <= tol_p * (1 + 1e-6)
    assert orientation.max() <= tol_o * (1 + 1e-6)
    # The tool really goes round the arc (not the chord): it passes the arc's middle.
    assert s.min() == 0.0 and s.max() >= 1.0 - 1e-3
    mid = c + _rz(0.5 * SWEEP) @ (T0[:3, 3] - c)
    assert np.linalg.norm(UR5.fk_many(dense(traj.positions))[:, :3, 3] - mid, axis=1).min() < 5e-3
    np.testing.assert_allclose(UR5.fk(traj.positions[0]), T0, atol=1e-9)
    T_end = UR5.fk(traj.positions[-1])
    if method in EXACT_END_METHODS:
        np.testing.assert_allclose(T_end, Tg, atol=1e-9)
    else:
        assert np.linalg.norm(T_end[:3, 3] - Tg[:3, 3]) <= GOAL_FRACTION * tol_p
    assert np.all(np.abs(traj.velocities) <= UR5.velocity_limits * (1 + 1e-6))
    np.testing.assert_allclose(traj.velocities[[0, -1]], 0.0, atol=1e-12)
    assert result.fraction == 1.0


def test_interim_gives_the_long_way_round() -> None:
    """An interim point on the far side makes the arc the 240-degree one through it."""
    sweep = 4.0 * math.pi / 3
    T0, Tg, c = circle_case(sweep)
    interim = c + _rz(0.5 * sweep) @ (T0[:3, 3] - c)
    task = CartesianTask(
        robot=UR5, q_start=UR5_HOME, T_goal=Tg, path=PathSpec("circ", interim=interim)
    )
    path = task.line()
    assert path.length == pytest.approx(RADIUS * sweep, rel=1e-12)
    traj = plan(task, "sampled").trajectory
    radius, height, orientation, s = arc_errors(
        UR5.fk_many(dense(traj.positions)), T0, Tg, c, sweep
    )
    assert np.hypot(radius, height).max() <= 1e-3 and orientation.max() <= 1e-2
    assert np.all(np.diff(s) >= -1e-6)  # round the long way, monotonically
    np.testing.assert_allclose(UR5.fk(traj.positions[-1]), Tg, atol=1e-9)


def test_path_rates_follow_the_arc_tangent() -> None:
    """J dq/ds is the arc's own tangent r theta (-sin, cos) (the test's closed form) plus the
    slerp's angular rate, at every walked point; d2q/ds2 matches a finite difference of dq/ds."""
    T0, Tg, c = circle_case()
    task = CartesianTask(robot=UR5, q_start=UR5_HOME, T_goal=Tg, path=PathSpec("circ", center=c))
    path = task.line()
    walk = walk_line(task, path)
    rates = path_rates(UR5, path, walk.positions)
    a0 = math.atan2(*(T0[:3, 3] - c)[1::-1])
    phi = a0 + walk.s * SWEEP
    tangent = RADIUS * SWEEP * np.stack([-np.sin(phi), np.cos(phi), 0.0 * phi], axis=1)
    omega = T0[:3, :3] @ np.array([TURN, 0.0, 0.0])
    J = np.stack([UR5.jacobian(q)[task_rows("pose")] for q in walk.positions])
    V = np.einsum("nij,nj->ni", J, rates.dq_ds)
    np.testing.assert_allclose(V[:, :3], tangent, atol=1e-6)
    np.testing.assert_allclose(V[:, 3:], np.broadcast_to(omega, V[:, 3:].shape), atol=1e-6)
    # Explicit s gives the same rates as the projection of the FK.
    explicit = path_rates(UR5, path, walk.positions, s=walk.s)
    np.testing.assert_allclose(explicit.dq_ds, rates.dq_ds, atol=1e-7)
    # d2q/ds2 against a central difference of dq/ds on the walked points.
    ds = np.diff(walk.s)
    fd = (rates.dq_ds[2:] - rates.dq_ds[:-2]) / (ds[1:] + ds[:-1])[:, None]
    mid = rates.d2q_ds2[1:-1]
    assert np.abs(fd - mid).max() <= 0.05 * np.abs(mid).max() + 1e-3


def test_prefix_keeps_the_circle() -> None:
    _, Tg, c = circle_case()
    task = CartesianTask(robot=UR5, q_start=UR5_HOME, T_goal=Tg, path=PathSpec("circ", center=c))
    full, part = task.line(), task.prefix(0.4).line()
    s = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(part.poses(s), full.poses(0.4 * s), atol=1e-12)


def _bad_paths() -> list[tuple[str, np.ndarray, PathSpec, str]]:
    """(case, goal pose, path, field) of circles that do not exist or are not unique."""
    T0, Tg, c = circle_case()
    half = T0.copy()  # a half turn: the centre is the chord's midpoint, the plane is free
    half[:3, 3] = c + _rz(math.pi) @ (T0[:3, 3] - c)
    chord_mid = 0.5 * (T0[:3, 3] + Tg[:3, 3])
    return [
        ("collinear interim", Tg, PathSpec("circ", interim=chord_mid), "interim"),
        ("centre 2e-4 m off", Tg, PathSpec("circ", center=c + np.array([2e-4, 0, 0])), "center"),
        ("half turn", half, PathSpec("circ", center=c), "center"),
        ("no circle", Tg, PathSpec("circ"), "interim"),
        ("line with a centre", Tg, PathSpec("line", center=c), "type"),
        ("unknown shape", Tg, PathSpec("spline"), "type"),
    ]


@pytest.mark.parametrize(("case", "goal", "spec", "where"), _bad_paths(), ids=lambda x: str(x)[:20])
def test_bad_circle_geometry_is_input_error_at_path(case, goal, spec, where) -> None:
    task = CartesianTask(robot=UR5, q_start=UR5_HOME, T_goal=goal, path=spec)
    with pytest.raises(InputError) as err:
        plan(task, "sampled")
    assert err.value.field == ("path", where), case


def test_centre_within_its_tolerance_is_accepted() -> None:
    """Start and goal 5e-5 m off equidistant (under the 1e-4 m bound): a plan, within tolerance."""
    _, Tg, c = circle_case()
    Tg = Tg.copy()
    Tg[:3, 3] += 5e-5 * (Tg[:3, 3] - c) / RADIUS
    task = CartesianTask(robot=UR5, q_start=UR5_HOME, T_goal=Tg, path=PathSpec("circ", center=c))
    traj = plan(task, "sampled").trajectory
    np.testing.assert_allclose(UR5.fk(traj.positions[-1]), Tg, atol=1e-9)


@pytest.mark.parametrize("method", ["sampled", "bounded_deviation", "resolved_rate"])
def test_partial_plan_stays_on_the_circle(method: str) -> None:
    """An arc that leaves the workspace: the planned prefix (fraction < 1) is on the same circle,
    its last point at the arc's pose at ``fraction`` (the knot methods re-plan the cut arc)."""
    T0 = UR5.fk(UR5_HOME)
    radius = 0.25
    c = T0[:3, 3] + np.array([-radius, 0.0, 0.0])
    Tg = T0.copy()
    Tg[:3, 3] = c + _rz(0.9 * math.pi) @ (T0[:3, 3] - c)
    task = CartesianTask(
        robot=UR5,
        q_start=UR5_HOME,
        T_goal=Tg,
        path=PathSpec("circ", center=c),
        allow_partial=True,
    )
    result = plan(task, method)
    assert 0.3 < result.fraction < 0.7 and result.failure is not None
    p = UR5.fk_many(dense(result.trajectory.positions))[:, :3, 3]
    assert np.abs(np.linalg.norm(p - c, axis=1) - radius).max() <= 1e-3
    assert np.abs(p[:, 2] - c[2]).max() <= 1e-3
    end = c + _rz(0.9 * math.pi * result.fraction) @ (T0[:3, 3] - c)
    assert np.linalg.norm(p[-1] - end) <= 1e-3


@pytest.mark.parametrize("method", METHODS)
def test_planar_arm_follows_a_circle_in_its_plane(method: str) -> None:
    """``position_xy``: the circle lies in the arm's plane (an interim point's z is ignored) and
    only x, y count; the tool point stays on the test's own circle through the three points."""
    robot = registry.get("planar_2r")
    q0 = np.array([0.3, 1.2])
    p0 = robot.fk(q0)[:3, 3]
    Tg = np.eye(4)
    Tg[:3, 3] = p0 + np.array([0.3, -0.2, 0.0])
    interim = p0 + np.array([0.2, 0.0, 7.0])
    task = CartesianTask(robot=robot, q_start=q0, T_goal=Tg, path=PathSpec("circ", interim=interim))
    traj = plan(task, method).trajectory
    # Circumcentre of the three points in the plane (the test's own).
    a, b, c3 = p0[:2], interim[:2], Tg[:2, 3]
    A = 2.0 * np.array([b - a, c3 - a])
    centre = np.linalg.solve(A, [b @ b - a @ a, c3 @ c3 - a @ a])
    radius = np.linalg.norm(a - centre)
    p = robot.fk_many(dense(traj.positions))[:, :2, 3]
    assert np.abs(np.linalg.norm(p - centre, axis=1) - radius).max() <= 1e-3
    tol = 1e-9 if method in EXACT_END_METHODS else GOAL_FRACTION * 1e-3
    assert np.linalg.norm(p[-1] - c3) <= tol
