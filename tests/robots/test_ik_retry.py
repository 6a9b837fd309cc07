"""The single-solution IK's second effort (robots.ik_retry): reachable poses of redundant arms.

Poses come from forward kinematics of random joint positions inside the limits, so a solution
exists; every answer is checked with pinocchio's FK of the robot's own model and against the limits.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from core.budget import Deadline
from robots import ik_retry, registry

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "urdf"


def panda_to_finger():
    """Panda with hand, tip at a finger: 7 revolute joints and a prismatic one, numeric IK."""
    urdf = (FIXTURES / "panda.urdf").read_text(encoding="utf-8")
    return registry.load_inline(urdf, "panda_leftfinger", "panda_link0")


def poses(robot, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = robot.position_limits.T
    qs = np.random.default_rng(seed).uniform(np.maximum(lo, -math.pi), np.minimum(hi, math.pi),
                                              (n, robot.dof))  # fmt: skip
    return qs, robot.fk_many(qs)


def assert_solves(robot, T: np.ndarray, q: np.ndarray) -> None:
    """``q`` inside the limits, and pinocchio's tip pose at ``q`` is ``T`` to 1e-9."""
    lo, hi = robot.position_limits.T
    assert np.all(q >= lo - 1e-12) and np.all(q <= hi + 1e-12)
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, q)
    tip = data.oMf[model.getFrameId(robot.tip_frame, pin.FrameType.BODY)]
    base = data.oMf[model.getFrameId(robot.base_frame, pin.FrameType.BODY)]
    err = pin.log6(base.actInv(tip).actInv(pin.SE3(T))).vector
    assert np.abs(err).max() <= 1e-9


@pytest.mark.parametrize(("name", "n"), [("panda", 24), ("panda_finger", 8)])
def test_reachable_poses_of_redundant_arms_are_solved(name: str, n: int) -> None:
    robot = registry.get("panda") if name == "panda" else panda_to_finger()
    qs, Ts = poses(robot, n, seed=5)
    missed_first = 0
    for q, T in zip(qs, Ts, strict=True):
        first = robot.ik_all(T)  # the redundant joints held at home's values
        missed_first += not len(first)
        one = robot.ik_one(T)
        assert len(one), f"no solution for the pose of q = {q.tolist()}"
        assert_solves(robot, T, one.positions[0])
        assert one.solver == robot.ik_solver
    # the first search alone misses some of them: the second effort is what found those
    assert missed_first > 0


def test_a_solved_pose_costs_no_second_search(monkeypatch: pytest.MonkeyPatch) -> None:
    robot = registry.get("panda")
    q = np.array([0.3, -0.5, 0.2, -2.0, 0.1, 1.6, robot.home[6]])
    called = []
    monkeypatch.setattr(ik_retry, "_held_sweep", lambda *a: called.append(a))
    one = robot.ik_one(robot.fk(q))
    assert not called and len(one)
    np.testing.assert_allclose(one.positions, robot.ik_all(robot.fk(q)).positions)


def test_complete_solvers_fixed_joints_far_goals_and_the_deadline_skip_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    calls = []
    monkeypatch.setattr(ik_retry, "_held_sweep", lambda *a: calls.append("sweep"))
    monkeypatch.setattr(ik_retry, "_released", lambda *a: calls.append("released"))
    ur5, panda = registry.get("ur5"), registry.get("panda")
    far = np.eye(4)
    far[:3, 3] = [3.0, 0.0, 0.5]
    assert not len(ur5.ik_one(far)) and not len(panda.ik_one(far))  # beyond the reach bound
    _, Ts = poses(panda, 40, seed=5)
    missed = next(T for T in Ts if not len(panda.ik_all(T)))
    assert not len(panda.ik_one(missed, fixed_joints={"panda_joint7": float(panda.home[6])}))
    assert not calls  # EAIK is complete for a 6R arm and for a held value the request fixes
    assert not len(panda.ik_one(missed, deadline=Deadline(0.0)))
    assert calls == ["sweep"]  # called, with no time to spend: it returns at once (nothing found)
    monkeypatch.undo()
    assert len(panda.ik_one(missed, deadline=Deadline(10.0)))


def test_the_answer_is_deterministic_and_keeps_fixed_joints() -> None:
    robot = panda_to_finger()
    qs, Ts = poses(robot, 8, seed=11)
    T = next(T for T in Ts if not len(robot.ik_all(T)))
    a, b = robot.ik_one(T), robot.ik_one(T)
    np.testing.assert_array_equal(a.positions, b.positions)
    q = qs[0].copy()
    q[7] = 0.02
    one = robot.ik_one(robot.fk(q), fixed_joints={"panda_finger_joint1": 0.02})
    assert len(one) and one.positions[0][7] == pytest.approx(0.02, abs=1e-12)
    assert_solves(robot, robot.fk(q), one.positions[0])
