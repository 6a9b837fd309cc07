"""Every IK solution (robots.ik, robots.ik_analytic) and configuration labels (robots.configurations).

References: pinocchio FK of the robot's own model (every solution), the Robotics Toolbox's analytic
PUMA 560 IK (Corke's eight ``ikine_a`` configurations), and a dense numeric multi-start search (no
solution exists outside ours).
"""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pinocchio as pin
import pytest

from core.errors import InputError, JointLimit
from robots import ik as robot_ik
from robots import ik_batch, registry
from robots.configurations import LABELS, WRIST_6R

TWO_PI = 2 * math.pi
UR5_URDF = resources.files("robots").joinpath("urdf", "ur5.urdf").read_text()


def wrap(d: np.ndarray) -> np.ndarray:
    return (d + math.pi) % TWO_PI - math.pi


def pin_errors(robot, qs: np.ndarray, T: np.ndarray) -> tuple[float, float]:
    """Worst position [m] and orientation [rad] error, from pinocchio on the robot's own model."""
    model, data = robot.model, robot.model.createData()
    tip = model.getFrameId(robot.tip_frame, pin.FrameType.BODY)
    goal = pin.SE3(np.linalg.inv(robot.chain.T_base_world) @ T)
    worst_p = worst_o = 0.0
    for q in qs:
        pin.framesForwardKinematics(model, data, q)
        err = pin.log6(data.oMf[tip].actInv(goal)).vector
        worst_p = max(worst_p, float(np.linalg.norm(data.oMf[tip].translation - goal.translation)))
        worst_o = max(worst_o, float(np.linalg.norm(err[3:])))
    return worst_p, worst_o


def random_q(robot, n: int, seed: int) -> np.ndarray:
    lo, hi = robot.position_limits.T
    return np.random.default_rng(seed).uniform(
        np.maximum(lo, -4), np.minimum(hi, 4), (n, robot.dof)
    )


def raw_solutions(robot, T: np.ndarray) -> np.ndarray:
    """EAIK's candidates that reproduce the pose (no joint limits)."""
    Q = robot.analytic_ik.solve(T)
    pe, oe = robot_ik.pose_errors(robot, Q, T)
    return Q[(pe <= 1e-9) & (oe <= 1e-9)]


@pytest.mark.parametrize("name", ["ur5", "puma560", "planar_2r", "panda"])
def test_every_solution_reproduces_the_pose_and_q_is_among_them(name: str) -> None:
    robot = registry.get(name)
    counts = []
    for q in random_q(robot, 60, seed=1):
        T = robot.fk(q)
        sol = robot.ik_all(T, q)
        counts.append(len(sol))
        assert np.abs(wrap(sol.positions[0] - q)).max() <= 1e-7  # nearest the seed q: q itself
        p, o = pin_errors(robot, sol.positions, T)
        assert (p <= 1e-9 and o <= 1e-9) or robot.task_space == "position_xy", (p, o)
        if robot.task_space == "position_xy":
            xy = robot.fk_many(sol.positions)[:, :2, 3]
            assert np.abs(xy - T[:2, 3]).max() <= 1e-9
        lo, hi = robot.position_limits.T
        assert np.all((sol.positions >= lo) & (sol.positions <= hi))
        assert sol.solver == "analytic"
        for a in range(len(sol)):  # distinct modulo 2 pi
            for b in range(a):
                assert np.abs(wrap(sol.positions[a] - sol.positions[b])).max() > 1e-6
        if robot.configuration_family is not None:
            assert len(set(sol.configurations)) == len(sol)
            assert list(sol.configurations) == [robot.configuration(x) for x in sol.positions]
    assert max(counts) == {"ur5": 8, "puma560": 8, "planar_2r": 2, "panda": max(counts)}[name]


@pytest.mark.parametrize("name", ["ur5", "puma560"])
def test_eight_solutions_eight_labels_over_many_poses(name: str) -> None:
    """Without joint limits a generic pose has 8 solutions for UR5 when all are real (PUMA: always),
    and their 8 labels are 8 different ones."""
    robot = registry.get(name)
    qs = np.random.default_rng(7).uniform(-math.pi, math.pi, (400, 6))
    eights = 0
    for q in qs:
        Q = raw_solutions(robot, robot.fk(q))
        assert np.abs(wrap(Q - q)).max(axis=1).min() <= 1e-7
        labels = robot.configurations(Q)
        assert len(set(labels)) == len(labels), labels
        eights += len(Q) == 8
    if name == "puma560":
        assert eights == len(qs)
    else:  # about a quarter of random UR5 poses have fewer than 8 real solutions
        assert 0.6 * len(qs) <= eights <= 0.9 * len(qs)


def test_puma_matches_the_robotics_toolbox_analytic_ik() -> None:
    """Corke's ikine_a gives one solution per configuration letter triple; each is one of ours, and
    carries our label of the same words (lun = left-up-noflip)."""
    rtb = pytest.importorskip("roboticstoolbox")
    puma = rtb.models.DH.Puma560()
    robot = registry.get("puma560")
    for q in np.random.default_rng(3).uniform(-math.pi, math.pi, (40, 6)):
        T = robot.fk(q)
        Q = raw_solutions(robot, T)
        ours = robot.configurations(Q)
        for config in ("lun", "luf", "ldn", "ldf", "run", "ruf", "rdn", "rdf"):
            ref = puma.ikine_a(T, config=config)
            assert ref.success
            k = int(np.argmin(np.abs(wrap(Q - ref.q)).max(axis=1)))
            assert np.abs(wrap(Q[k] - ref.q)).max() <= 1e-7
            letters = {
                "l": "left",
                "r": "right",
                "u": "up",
                "d": "down",
                "n": "noflip",
                "f": "flip",
            }
            assert ours[k] == "-".join(letters[c] for c in config)


def test_no_solution_outside_ours_dense_numeric_search() -> None:
    """From 300 starting points, damped Newton finds nothing that is not one of the 8 (UR5)."""
    robot = registry.get("ur5")
    lower, upper = robot.position_limits.T
    for q in random_q(robot, 3, seed=11):
        T = robot.fk(q)
        Q = raw_solutions(robot, T)
        for start in np.random.default_rng(5).uniform(-math.pi, math.pi, (300, 6)):
            r = robot.ik_from(
                T, start, (lower, upper, robot.revolute), max_iterations=100, tolerance=1e-10
            )
            if r.position_error <= 1e-9 and r.orientation_error <= 1e-9:
                assert np.abs(wrap(Q - r.positions)).max(axis=1).min() <= 1e-6


def test_turns_give_every_2pi_variant_within_the_limits() -> None:
    robot = registry.get("ur5")  # every joint +-2 pi: 2 variants per joint, 64 per solution
    q = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
    T = robot.fk(q)
    one, every = robot.ik_all(T, q), robot.ik_all(T, q, turns=True)
    assert len(every) == 64 * len(one)
    for x in every.positions:  # each is a turn variant of exactly one solution
        d = np.abs(wrap(one.positions - x)).max(axis=1)
        assert d.min() <= 1e-9 and np.sort(d)[1] > 1e-6
    assert robot_ik.pose_errors(robot, every.positions, T)[0].max() <= 1e-9
    # nearest-the-seed order, and the seed's own turn is the first of its variants
    dist = np.linalg.norm(every.positions - q, axis=1)
    assert np.all(np.diff(dist) >= 0) and dist[0] <= 1e-9


def test_panda_holds_the_redundant_joint() -> None:
    robot = registry.get("panda")
    assert robot.redundant_joints == ("panda_joint7",) and robot.ik_solver == "analytic"
    q = np.array([0.2, -0.5, 0.3, -2.0, 0.4, 1.7, 0.6])
    T = robot.fk(q)
    sol = robot.ik_all(T, q + 0.1)  # held at the seed's q7 = 0.7: q itself is not a solution
    assert np.all(np.abs(sol.positions[:, 6] - 0.7) <= 1e-12) and len(sol) >= 1
    assert pin_errors(robot, sol.positions, T)[0] <= 1e-9
    fixed = robot.ik_all(T, q + 0.1, fixed_joints={"panda_joint7": 0.6})
    assert np.abs(wrap(fixed.positions[0] - q)).max() <= 1e-7
    assert np.all(fixed.positions[:, 6] == 0.6)
    with pytest.raises(InputError) as err:
        robot.ik_all(T, q, fixed_joints={"panda_joint2": 0.0})
    assert err.value.field == ("fixed_joints", "panda_joint2")
    with pytest.raises(InputError):
        robot.ik_all(T, q, fixed_joints={"nope": 0.0})
    with pytest.raises(JointLimit):
        robot.ik_all(T, q, fixed_joints={"panda_joint7": 4.0})


def test_inline_ur_family_urdfs_get_analytic_ik_with_base_and_tool_offsets() -> None:
    """UR3 and UR10 (scaled UR5 text with their DH numbers), on a base offset and a tool offset that
    EAIK's own FK would leave out."""
    dims = {
        "ur3": (0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
        "ur10": (0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
    }
    for name, (d1, a2, a3, d4, d5, d6) in dims.items():
        urdf = ur_urdf(d1, a2, a3, d4, d5, d6)
        robot = registry.load_inline(urdf, "tool", "world")
        assert robot.ik_solver == "analytic", name
        assert robot.configuration_family == WRIST_6R
        for q in random_q(robot, 30, seed=4):
            T = robot.fk(q)
            sol = robot.ik_all(T, q)
            assert np.abs(wrap(sol.positions[0] - q)).max() <= 1e-7
            assert pin_errors(robot, sol.positions, T)[0] <= 1e-9
            assert len(set(sol.configurations)) == len(sol)


def ur_urdf(d1, a2, a3, d4, d5, d6) -> str:
    """A UR-family arm from its DH numbers (URDF convention of ur_description), on a pedestal 0.3 m
    high and rotated, with a tool 0.12 m out along and tilted from the flange."""
    h = math.pi / 2
    j = (
        '<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/>'
        '<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/>'
        '<limit lower="-6.28" upper="6.28" velocity="3" effort="1"/></joint>'
    )
    f = '<joint name="{n}" type="fixed"><parent link="{p}"/><child link="{c}"/><origin xyz="{xyz}" rpy="{rpy}"/></joint>'
    parts = [
        f.format(n="pedestal", p="world", c="base", xyz="0.1 -0.2 0.3", rpy="0 0 0.7"),
        j.format(n="j1", p="base", c="l1", xyz=f"0 0 {d1}", rpy="0 0 0"),
        j.format(n="j2", p="l1", c="l2", xyz="0 0 0", rpy=f"{h} 0 0"),
        j.format(n="j3", p="l2", c="l3", xyz=f"{a2} 0 0", rpy="0 0 0"),
        j.format(n="j4", p="l3", c="l4", xyz=f"{a3} 0 {d4}", rpy="0 0 0"),
        j.format(n="j5", p="l4", c="l5", xyz=f"0 {-d5} 0", rpy=f"{h} 0 0"),
        j.format(n="j6", p="l5", c="l6", xyz=f"0 {d6} 0", rpy=f"{-h} 0 0"),
        f.format(n="tool_mount", p="l6", c="tool", xyz="0.01 0.02 0.12", rpy="0.3 0 0.2"),
    ]
    links = "".join(
        f'<link name="{n}"/>' for n in ["world", "base", "l1", "l2", "l3", "l4", "l5", "l6", "tool"]
    )
    return f'<?xml version="1.0"?><robot name="ur">{links}{"".join(parts)}</robot>'


def test_inline_6r_without_a_decomposition_is_numeric_and_deduplicated() -> None:
    """A 6R arm with skewed axes (no three parallel or intersecting): numeric from several seeds."""
    from tests.robots.inline_urdfs import joint, robot

    urdf = robot(
        joint("a", "b0", "b1", xyz="0 0 0.3", axis="0 0 1"),
        joint("b", "b1", "b2", xyz="0.05 0.02 0.1", axis="0 1 0.2"),
        joint("c", "b2", "b3", xyz="0.3 0 0.05", axis="0.1 1 0"),
        joint("d", "b3", "b4", xyz="0.25 0.03 0", axis="1 0 0.3"),
        joint("e", "b4", "b5", xyz="0.05 0.04 0.02", axis="0 1 0"),
        joint("f", "b5", "b6", xyz="0.06 0 0.01", axis="1 0.2 0"),
        links=["b0", "b1", "b2", "b3", "b4", "b5", "b6"],
    )
    r = registry.load_inline(urdf, "b6", "b0")
    assert r.ik_solver == "numeric" and r.configuration_family is None
    q = np.array([0.3, -0.4, 0.6, 0.2, -0.5, 0.4])
    T = r.fk(q)
    sol = r.ik_all(T, q)
    assert sol.solver == "numeric" and np.abs(sol.positions[0] - q).max() <= 1e-7
    assert pin_errors(r, sol.positions, T)[0] <= 1e-9
    for a in range(len(sol)):
        for b in range(a):
            assert np.abs(wrap(sol.positions[a] - sol.positions[b])).max() > 1e-6


def test_wrist_singular_pose_returns_representatives_with_a_warning() -> None:
    robot = registry.get("ur5")
    q = np.array([0.3, -1.2, 1.8, -2.2, 0.0, 0.4])  # q5 = 0: axes 4 and 6 aligned
    T = robot.fk(q)
    sol = robot.ik_all(T, q)
    assert len(sol) >= 1 and sol.warnings and "singular" in sol.warnings[0]
    assert pin_errors(robot, sol.positions, T)[0] <= 1e-9
    generic = robot.ik_all(robot.fk(q + 0.3), q)
    assert generic.warnings == ()


def test_unreachable_pose_has_no_solutions() -> None:
    robot = registry.get("ur5")
    T = np.eye(4)
    T[:3, 3] = [3.0, 0.0, 0.5]
    assert len(robot.ik_all(T)) == 0


def test_labels_are_listed_and_planar_up_down() -> None:
    assert registry.get("ur5").configuration_labels == LABELS[WRIST_6R]
    planar = registry.get("planar_2r")
    assert planar.configuration(np.array([0.2, 0.5])) == "down"
    assert planar.configuration(np.array([0.2, -0.5])) == "up"
    assert registry.get("panda").configuration_labels == ()


@pytest.mark.parametrize(
    ("name", "count"),
    [
        ("ur5", 150),
        ("puma560", 150),
        ("panda", 30),  # 0.14 s a pose, each solved twice: 30 in the default run, 150 in -m slow
        pytest.param("panda", 150, marks=pytest.mark.slow),
    ],
)
def test_batched_ik_all_equals_one_pose_at_a_time(name: str, count: int) -> None:
    robot = registry.get(name)
    qs = random_q(robot, count, seed=21)
    Ts = robot.fk_many(qs)
    many = robot.ik_all_many(Ts, robot.home)
    for T, batch in zip(Ts, many, strict=True):
        one = robot.ik_all(T, robot.home)
        assert len(batch) == len(one) and batch.configurations == one.configurations
        assert np.abs(batch.positions - one.positions).max(initial=0) <= 1e-12
        assert batch.solver == one.solver


def line_poses(robot, q0: np.ndarray, q1: np.ndarray, n: int) -> np.ndarray:
    """Poses on the straight line from FK(q0) to FK(q1), orientation by slerp (scipy)."""
    from scipy.spatial.transform import Rotation, Slerp

    A, B = robot.fk(q0), robot.fk(q1)
    s = np.linspace(0, 1, n)
    Ts = np.zeros((n, 4, 4))
    Ts[:, :3, :3] = Slerp([0, 1], Rotation.from_matrix([A[:3, :3], B[:3, :3]]))(s).as_matrix()
    Ts[:, :3, 3] = A[:3, 3] + s[:, None] * (B[:3, 3] - A[:3, 3])
    Ts[:, 3, 3] = 1
    return Ts


def test_ik_many_follows_the_start_configuration_along_a_line() -> None:
    robot = registry.get("ur5")
    q0 = np.array([0.0, -1.0, 1.5, -2.0, -1.5, 0.3])
    Ts = line_poses(robot, q0, np.array([0.6, -1.3, 1.9, -2.3, -1.2, 0.8]), 200)
    path = robot.ik_many(Ts, q0)
    assert path.solver == "analytic" and path.found.all() and path.within_limits.all()
    assert path.configuration == robot.configuration(q0)
    assert set(robot.configurations(path.positions)) == {path.configuration}
    assert ik_batch.pose_errors_many(robot, path.positions, Ts)[0].max() <= 1e-9
    assert np.abs(np.diff(np.vstack([q0, path.positions]), axis=0)).max() < 0.05  # no jump
    # the same as damped Newton from the previous sample, sample by sample
    previous, numeric = q0, []
    for T in Ts:
        previous = robot.ik(T, previous, position_tolerance=1e-11, orientation_tolerance=1e-11)[0]
        numeric.append(previous)
    assert np.abs(np.array(numeric) - path.positions).max() <= 1e-8
    # another branch on request: every row carries it
    other = robot.ik_many(Ts, q0, configuration="right-down-flip")
    assert set(robot.configurations(other.positions[other.found])) <= {"right-down-flip"}


def test_ik_many_marks_poses_without_the_label() -> None:
    """A line running out of reach: the start's branch ends (it merges with another at a
    singularity, or the pose leaves the workspace); ``found`` says where."""
    robot = registry.get("ur5")
    q0 = np.array([0.0, -1.0, 1.5, -2.0, -1.5, 0.3])
    T0 = robot.fk(q0)
    far = T0.copy()
    far[:3, 3] = [2.0, 0.0, 0.4]
    s = np.linspace(0, 1, 101)
    Ts = np.repeat(T0[None], len(s), axis=0)
    Ts[:, :3, 3] = T0[:3, 3] + s[:, None] * (far[:3, 3] - T0[:3, 3])
    path = robot.ik_many(Ts, q0)
    # found exactly where the start's label is among the pose's solutions; none at the far end
    for T, found in zip(Ts, path.found, strict=True):
        assert found == (path.configuration in robot.ik_all(T, q0).configurations)
    assert path.found[:10].all() and not path.found[-10:].any()
    assert all(len(robot.ik_all(T)) == 0 for T in Ts[-10:])


def test_turns_on_continuous_joints_are_bounded() -> None:
    from tests.robots.inline_urdfs import joint, robot

    urdf = robot(
        joint("a", "b0", "b1", "continuous", axis="0 0 1"),
        joint("b", "b1", "b2", "continuous", xyz="1 0 0", axis="0 0 1"),
        joint("t", "b2", "tip", "fixed", xyz="0.8 0 0"),
        links=["b0", "b1", "b2", "tip"],
    )
    r = registry.load_inline(urdf, "tip", "b0")
    T = r.fk(np.array([0.3, 0.9]))
    assert len(r.ik_all(T)) == 2  # both elbows, each once
    with pytest.raises(InputError) as err:
        r.ik_all(T, turns=True)
    assert err.value.field == ("turns",)


def hawkins_count(T: np.ndarray) -> int | None:
    """Independent count of the UR5's real IK solutions (Hawkins 2013, "Analytic inverse kinematics
    for the Universal Robots UR-5/UR-10 arms"): 2 shoulder roots x 2 wrist roots x 2 elbow roots,
    each pair real or not. None when a root sits within 1e-6 of the boundary (degenerate)."""
    d1, a2, a3, d4, d5, d6 = 0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823
    d, a, alpha = (
        [d1, 0, 0, d4, d5, d6],
        [0, a2, a3, 0, 0, 0],
        [math.pi / 2, 0, 0, math.pi / 2, -math.pi / 2, 0],
    )

    def dh(i: int, theta: float) -> np.ndarray:
        ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha[i]), math.sin(alpha[i])
        return np.array(
            [
                [ct, -st * ca, st * sa, a[i] * ct],
                [st, ct * ca, -ct * sa, a[i] * st],
                [0, sa, ca, d[i]],
                [0, 0, 0, 1],
            ]
        )

    p05 = T @ np.array([0, 0, -d6, 1])
    r = math.hypot(p05[0], p05[1])
    if abs(d4 / r - 1) < 1e-6:
        return None
    if d4 > r:
        return 0
    psi, phi = math.atan2(p05[1], p05[0]), math.acos(d4 / r)
    count = 0
    for q1 in (psi + phi + math.pi / 2, psi - phi + math.pi / 2):
        c5 = (T[0, 3] * math.sin(q1) - T[1, 3] * math.cos(q1) - d4) / d6
        if abs(abs(c5) - 1) < 1e-6:
            return None
        if abs(c5) > 1:
            continue
        for q5 in (math.acos(c5), -math.acos(c5)):
            T60 = np.linalg.inv(T)
            s5 = math.sin(q5)
            q6 = math.atan2(
                (-T60[1, 0] * math.sin(q1) + T60[1, 1] * math.cos(q1)) / s5,
                (T60[0, 0] * math.sin(q1) - T60[0, 1] * math.cos(q1)) / s5,
            )
            T14 = np.linalg.inv(dh(0, q1)) @ T @ np.linalg.inv(dh(4, q5) @ dh(5, q6))
            p13 = T14 @ np.array([0, -d4, 0, 1]) - np.array([0, 0, 0, 1])
            c3 = (p13[:3] @ p13[:3] - a2 * a2 - a3 * a3) / (2 * a2 * a3)
            if abs(abs(c3) - 1) < 1e-6:
                return None
            count += 2 if abs(c3) < 1 else 0
    return count


def test_ur5_solution_count_equals_the_independent_closed_form_count() -> None:
    robot = registry.get("ur5")
    qs = np.random.default_rng(17).uniform(-math.pi, math.pi, (300, 6))
    checked = 0
    for q in qs:
        T = robot.fk(q)
        expected = hawkins_count(T)
        if expected is None:
            continue
        assert len(raw_solutions(robot, T)) == expected
        checked += 1
    assert checked >= 290
