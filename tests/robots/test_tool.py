"""A tool offset (TCP): ``Robot.with_tool(T_tip_tool)`` answers for the tool frame. Checked against
pinocchio's FK of the untouched model times the offset, finite differences, and FK of every IK
solution (EAIK with the offset handled outside it, the planar closed form, damped Newton)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from core.errors import InputError
from robots import registry
from tests.robots.inline_urdfs import OFFSET_BASE_URDF

TOOL = np.eye(4)
TOOL[:3, :3] = pin.rpy.rpyToMatrix(0.3, -0.5, 1.1)
TOOL[:3, 3] = [0.05, -0.12, 0.21]
PLANAR_TOOL = np.eye(4)
PLANAR_TOOL[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, 0.7)
PLANAR_TOOL[:3, 3] = [0.15, 0.3, 0.0]


def reference_fk(arm, q: np.ndarray, T_tip_tool: np.ndarray) -> np.ndarray:
    """pinocchio FK of the arm's own model (its tip frame) times the offset, in the base frame."""
    model = arm.model
    data = pin.Data(model)
    pin.forwardKinematics(model, data, q)
    tip = pin.updateFramePlacement(
        model, data, model.getFrameId(arm.tip_frame, pin.FrameType.BODY)
    ).homogeneous
    base = pin.updateFramePlacement(
        model, data, model.getFrameId(arm.base_frame, pin.FrameType.BODY)
    ).homogeneous
    return np.linalg.inv(base) @ tip @ T_tip_tool


def robots_and_tools():
    return [
        (registry.get("ur5"), TOOL),
        (registry.get("puma560"), TOOL),
        (registry.get("panda"), TOOL),
        (registry.get("planar_2r"), PLANAR_TOOL),
        (registry.load_inline(OFFSET_BASE_URDF, "tool"), TOOL),
    ]


@pytest.mark.parametrize("k", range(5))
def test_fk_and_jacobians_follow_the_tool_frame(k: int) -> None:
    arm, T = robots_and_tools()[k]
    robot = arm.with_tool(T)
    rng = np.random.default_rng(k)
    lo, hi = np.maximum(arm.position_limits[:, 0], -3), np.minimum(arm.position_limits[:, 1], 3)
    qs = rng.uniform(lo, hi, (20, arm.dof))
    many = robot.fk_many(qs)
    for q, F in zip(qs, many, strict=True):
        ref = reference_fk(arm, q, T)
        np.testing.assert_allclose(robot.fk(q), ref, atol=1e-12)
        np.testing.assert_allclose(F, ref, atol=1e-12)
        p, R = robot.fk_casadi()(q)
        np.testing.assert_allclose(np.asarray(p).ravel(), ref[:3, 3], atol=1e-12)
        np.testing.assert_allclose(np.asarray(R), ref[:3, :3], atol=1e-12)
        J = robot.jacobian(q)
        h = 1e-7
        for j in range(arm.dof):  # the tool point's velocity and the frame's angular velocity
            dq = np.zeros(arm.dof)
            dq[j] = h
            Tp, Tm = reference_fk(arm, q + dq, T), reference_fk(arm, q - dq, T)
            np.testing.assert_allclose(J[:3, j], (Tp[:3, 3] - Tm[:3, 3]) / (2 * h), atol=1e-6)
            W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ ref[:3, :3].T
            np.testing.assert_allclose(J[3:, j], [W[2, 1], W[0, 2], W[1, 0]], atol=1e-6)
    np.testing.assert_allclose(robot.jacobian_many(qs)[3], robot.jacobian(qs[3]), atol=1e-12)
    links, ref_links = robot.link_frames(qs[0]), arm.link_frames(qs[0])  # the links are unchanged
    assert [n for n, _ in links] == [n for n, _ in ref_links]
    np.testing.assert_allclose([F for _, F in links], [F for _, F in ref_links], atol=1e-15)


@pytest.mark.parametrize("k", range(5))
def test_every_ik_solution_puts_the_tool_on_the_pose(k: int) -> None:
    """IK of tool poses: every solution's pinocchio FK (of the untouched model, times the offset)
    reproduces the pose; analytic solvers stay analytic and find as many solutions as for the
    flange."""
    arm, T = robots_and_tools()[k]
    robot = arm.with_tool(T)
    rng = np.random.default_rng(10 + k)
    lo, hi = np.maximum(arm.position_limits[:, 0], -3), np.minimum(arm.position_limits[:, 1], 3)
    assert robot.ik_solver == arm.ik_solver
    for q in rng.uniform(lo, hi, (6, arm.dof)):
        goal = reference_fk(arm, q, T)
        found = robot.ik_all(goal, q)
        assert len(found) >= 1
        for sol in found.positions:
            got = reference_fk(arm, sol, T)
            if arm.task_space == "position_xy":
                np.testing.assert_allclose(got[:2, 3], goal[:2, 3], atol=1e-9)
            else:
                np.testing.assert_allclose(got, goal, atol=1e-8)
        flange = arm.ik_all(goal @ np.linalg.inv(T), q)  # the same arm configurations
        assert len(found) == len(flange)
        one = robot.ik(goal, q)
        assert one.success
        np.testing.assert_allclose(
            reference_fk(arm, one.positions, T)[:3, 3], goal[:3, 3], atol=1e-6
        )
    path = robot.ik_many(np.array([goal, goal]), found.positions[0])
    assert path.found.all()


def test_configuration_labels_of_a_6r_arm_do_not_depend_on_the_tool() -> None:
    arm = registry.get("ur5")
    robot = arm.with_tool(TOOL)
    qs = np.random.default_rng(3).uniform(-3, 3, (50, 6))
    assert robot.configurations(qs) == arm.configurations(qs)
    assert robot.configuration_labels == arm.configuration_labels


def test_a_tool_is_checked_and_built_once() -> None:
    arm = registry.get("ur5")
    assert arm.with_tool(TOOL) is arm.with_tool(TOOL.copy())
    assert arm.with_tool(TOOL).with_tool(np.eye(4)).fk(arm.home) == pytest.approx(arm.fk(arm.home))
    assert arm.with_tool(TOOL).arm is arm and arm.arm is arm
    far = TOOL.copy()
    far[0, 3] = 10.5
    with pytest.raises(InputError) as info:
        arm.with_tool(far)
    assert info.value.field == ("tool", "position")
    skew = TOOL.copy()
    skew[:3, :3] *= 1.01
    with pytest.raises(InputError) as info:
        arm.with_tool(skew)
    assert info.value.field == ("tool", "orientation")
    bad = TOOL.copy()
    bad[1, 3] = np.nan
    with pytest.raises(InputError):
        arm.with_tool(bad)
