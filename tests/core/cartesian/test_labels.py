"""Configuration labels on Cartesian lines (issue 14): ``on_label`` decides a failed pose exactly,
``check_labels`` finds the first returned point off the start's label, the toy models' defaults.

References: the planar arm's closed form (reach l1 + l2 = 1.8 m, elbow from the law of cosines)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.cartesian.check import check_labels, finish
from core.cartesian.ik_on_path import on_label
from core.cartesian.plan import plan
from core.cartesian.task import CartesianResult, CartesianTask
from core.cartesian.walk import walk_line
from core.cartesian.walk_batch import batch_walk
from core.errors import BranchFlip, Singularity, Unreachable
from core.trajectory import Trajectory
from tests.core.conftest import registry_robot
from tests.toy_kinematics import LabelledToy, ToyPlanar2R


def at(x: float, y: float) -> np.ndarray:
    T = np.eye(4)
    T[:2, 3] = [x, y]
    return T


def elbow(x: float, y: float, sign: float) -> np.ndarray:
    q2 = sign * math.acos((x * x + y * y - 1.64) / 1.6)
    return np.array(
        [math.atan2(y, x) - math.atan2(0.8 * math.sin(q2), 1.0 + 0.8 * math.cos(q2)), q2]
    )


def test_toy_defaults_have_no_labels_and_one_solution():
    toy = ToyPlanar2R()
    q = np.array([0.3, 0.9])
    assert toy.configuration(q) is None and toy.configurations(np.stack([q, q])) == [None, None]
    sols = toy.ik_all(toy.fk(q), q)
    assert sols.configurations == (None,) and np.allclose(sols.positions[0], q, atol=1e-12)
    off = toy.ik_all(at(2.0, 0.0), q)
    assert len(off.positions) == 0 and off.outside_limits == 0


def test_on_label_returns_the_start_label_solution_nearest_the_seed():
    toy = LabelledToy()
    for sign, label in ((1.0, "down"), (-1.0, "up")):
        q = on_label(toy, at(0.9, 0.6), 0.5, label, elbow(0.9, 0.6, sign) + 0.01)
        assert isinstance(q, np.ndarray) and toy.configuration(q) == label
        assert np.allclose(q, elbow(0.9, 0.6, sign), atol=1e-12)


def test_on_label_tells_unreachable_from_branch_flip():
    """``on_label`` raises why there is no solution (issue 23: it returned ``array | error``)."""
    toy = LabelledToy()
    with pytest.raises(Unreachable) as off:
        on_label(toy, at(1.81, 0.0), 0.7, "down", np.zeros(2))
    assert off.value.s == 0.7
    with pytest.raises(BranchFlip) as flip:
        on_label(toy, at(1.3, 0.5), 0.4, "down", np.zeros(2))  # past x_cut: only "up"
    assert flip.value.s == 0.4 and "up" in str(flip.value)
    assert isinstance(on_label(toy, at(1.3, 0.5), 0.4, "up", np.zeros(2)), np.ndarray)


def test_on_label_at_the_rim_is_the_limit_of_both_branches():
    """At |p| = l1 + l2 exactly the one solution is stretched (q2 = 0, label down, singular): it
    ends the up branch too, so a line there is not a branch flip."""
    toy = LabelledToy()
    q = on_label(toy, at(1.8, 0.0), 0.4, "up", np.array([0.0, -0.01]))
    assert isinstance(q, np.ndarray) and abs(q[1]) < 1e-7


@pytest.mark.parametrize("method", ["sampled", "bounded_deviation", "bounded_deviation_nlp"])
def test_a_line_losing_its_start_label_is_a_branch_flip_where_it_is_lost(method):
    """From (0.7, 0.5) to (1.5, 0.5) the down solutions end at x = 1.1: s = 0.5."""
    toy = LabelledToy()
    task = CartesianTask(robot=toy, q_start=elbow(0.7, 0.5, 1.0), T_goal=at(1.5, 0.5))
    with pytest.raises(BranchFlip) as err:
        plan(task, method)
    assert abs(err.value.s - 0.5) <= 0.01


def test_check_labels_finds_the_first_point_off_the_start_label():
    toy = LabelledToy()
    q = np.array([[0.1, 0.3], [0.1, 0.2], [0.1, -0.1], [0.1, 0.2]])  # the middle of 2-3: 0.05
    traj = Trajectory(np.arange(4.0), q, np.zeros_like(q), np.zeros_like(q), toy.joint_names)
    task = CartesianTask(robot=toy, q_start=q[0], T_goal=toy.fk(q[-1]))
    flip = check_labels(task, traj, np.array([0.0, 0.3, 0.6, 1.0]))
    assert isinstance(flip, BranchFlip) and flip.s == 0.6 and "down" in str(flip)
    assert check_labels(task, Trajectory(traj.times[:2], q[:2], q[:2] * 0, q[:2] * 0)) is None
    result = CartesianResult(trajectory=traj, fraction=1.0)
    with pytest.raises(BranchFlip):
        finish(task, result)
    allowed = CartesianTask(robot=toy, q_start=q[0], T_goal=toy.fk(q[-1]), allow_violations=True)
    assert any("down" in w for w in finish(allowed, result).warnings)


def test_batch_walk_is_the_point_by_point_walk_where_the_line_is_clean():
    """UR5: the batched walk (ik_many on the start's label) gives the walk's points to 1e-8 rad;
    a line through the PUMA's wrist singularity and a line off the UR5's workspace are left to
    the point-by-point walk (None)."""
    ur5 = registry_robot("ur5")
    q0 = np.array([0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0])
    qg = np.array([0.3, -1.2, 1.8, -2.2, -1.3, 0.4])
    task = CartesianTask(robot=ur5, q_start=q0, T_goal=ur5.fk(qg))
    fast, slow = batch_walk(task, task.line()), walk_line(task, task.line())
    assert fast is not None and slow.failure is None
    assert np.array_equal(fast.s, slow.s) and np.abs(fast.positions - slow.positions).max() < 1e-8
    assert np.allclose(ur5.fk_many(fast.positions), task.line().poses(fast.s), atol=1e-9)
    far = ur5.fk(q0)
    far[0, 3] -= 0.8
    off = CartesianTask(robot=ur5, q_start=q0, T_goal=far)
    assert batch_walk(off, off.line()) is None
    puma = registry_robot("puma560")
    qa = np.array([0.0, 0.6, -2.6, 0.3, 0.25, 0.0])
    wrist = CartesianTask(puma, qa, puma.fk(np.array([0.2, 0.7, -2.4, 0.32, -0.25, 0.0])))
    assert batch_walk(wrist, wrist.line()) is None
    toy = CartesianTask(robot=LabelledToy(), q_start=elbow(0.7, 0.5, 1.0), T_goal=at(1.0, 0.5))
    assert batch_walk(toy, toy.line()) is None  # position_xy: the walk


def test_check_labels_between_points_on_the_controllers_spline():
    """Both points 'down' (q2 = 0.3, 0.05) but the cubic Hermite spline through them with q2' =
    -3, 0 rad/s dips to 0.175 - 3/8 = -0.2 rad (label 'up') at the middle of the interval."""
    toy = LabelledToy()
    q = np.array([[0.1, 0.3], [0.1, 0.05], [0.1, 0.2]])
    v = np.zeros_like(q)
    v[0, 1] = -3.0
    traj = Trajectory(np.arange(3.0), q, v, np.zeros_like(q), toy.joint_names)
    task = CartesianTask(robot=toy, q_start=q[0], T_goal=toy.fk(q[-1]))
    flip = check_labels(task, traj, np.array([0.0, 0.4, 1.0]))
    assert isinstance(flip, BranchFlip) and flip.s == pytest.approx(0.2, abs=1e-12)
    v[0, 1] = -1.0  # dips to 0.175 - 1/8 = 0.05: stays 'down'
    assert check_labels(task, Trajectory(traj.times, q, v, v * 0), np.array([0, 0.4, 1])) is None


@pytest.mark.parametrize("method", ["sampled", "bounded_deviation", "bounded_deviation_nlp"])
def test_a_line_through_the_wrist_singularity_is_a_singularity_for_every_method(method):
    """PUMA 560: q5 from +0.3 to -0.3 rad with the other joints held is a line in the tool's
    frame whose wrist passes q5 = 0 (axes 4 and 6 aligned) at s = 0.5 (by symmetry); the start's
    wrist label could be kept only by a half turn of q4 and q6 there. The knot methods returned
    200 through it with the wrist label flipped; now every method answers singularity there."""
    puma = registry_robot("puma560")
    qa = np.array([0.0, math.pi / 4, -math.pi, 0.0, 0.3, 0.0])
    qb = qa * np.array([1, 1, 1, 1, -1, 1])
    with pytest.raises(Singularity) as err:
        plan(CartesianTask(robot=puma, q_start=qa, T_goal=puma.fk(qb)), method)
    assert abs(err.value.s - 0.5) <= 0.01
