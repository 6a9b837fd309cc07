"""/v1/robots: the registered robots, their limits, forward and inverse kinematics."""

from __future__ import annotations

import numpy as np
from fastapi import APIRouter, Path

from core.errors import InputError, JointLimit, Unreachable
from robots import ik as robot_ik
from robots import registry
from robots.model import Robot
from service.schemas.common import PROBLEM_RESPONSES, Pose
from service.schemas.robots import (
    NAME_PATTERN,
    FKRequest,
    FKResponse,
    IKRequest,
    IKResponse,
    RobotDetail,
    RobotLimits,
    RobotSummary,
)

router = APIRouter(prefix="/v1/robots", tags=["robots"])
RobotName = Path(pattern=NAME_PATTERN, description="Registered robot name, for example ur5.")


def _summary(robot: Robot) -> dict:
    return {
        "name": robot.name,
        "dof": robot.dof,
        "joint_names": list(robot.joint_names),
        "base_frame": robot.base_frame,
        "tip_frame": robot.tip_frame,
        "task_space": robot.task_space,
    }


def _check_positions(robot: Robot, positions: list[float], field: str) -> np.ndarray:
    """Length equal to the robot's dof (422 validation), values inside the limits (422 joint_limit)."""
    q = np.asarray(positions, dtype=float)
    if q.shape != (robot.dof,):
        raise InputError(f"{field} needs {robot.dof} values, one per joint", field=(field,))
    lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
    bad = np.flatnonzero((q < lo) | (q > hi))
    if bad.size:
        j = int(bad[0])
        raise JointLimit(
            f"{field}[{j}] is outside the position limits of joint '{robot.joint_names[j]}'",
            field=(field, j),
            joint=j,
            extra={"joint_name": robot.joint_names[j], "limits": robot.position_limits[j].tolist()},
        )
    return q


@router.get("", response_model=list[RobotSummary], summary="Registered robots")
def list_robots() -> list[dict]:
    return [_summary(registry.get(name)) for name in registry.names()]


@router.get(
    "/{name}",
    response_model=RobotDetail,
    responses=PROBLEM_RESPONSES,
    summary="One robot, with limits",
)
def get_robot(name: str = RobotName) -> RobotDetail:
    robot = registry.get(name)
    return RobotDetail(
        **_summary(robot),
        limits=RobotLimits(
            position=robot.position_limits.tolist(),
            velocity=robot.velocity_limits.tolist(),
            acceleration=robot.acceleration_limits.tolist(),
            jerk=None if robot.jerk_limits is None else robot.jerk_limits.tolist(),
        ),
        home=robot.home.tolist(),
        limit_sources=dict(robot.sources),
    )


@router.post(
    "/{name}/fk",
    response_model=FKResponse,
    responses=PROBLEM_RESPONSES,
    summary="Forward kinematics: pose, Jacobian, singular values",
)
def forward_kinematics(body: FKRequest, name: str = RobotName) -> FKResponse:
    robot = registry.get(name)
    q = _check_positions(robot, body.positions, "positions")
    if body.frame is None:
        T, J = robot.fk(q), robot.jacobian(q)
    else:
        T, J = robot.frame_pose(q, body.frame), robot.jacobian(q, body.frame)
    s = robot.singular_values(q, J)
    return FKResponse(
        pose=Pose.from_matrix(T),
        jacobian=J.tolist(),
        min_singular_value=float(s[-1]),
        manipulability=float(np.prod(s)),
    )


@router.post(
    "/{name}/ik",
    response_model=IKResponse,
    responses=PROBLEM_RESPONSES,
    summary="Inverse kinematics of the tool pose (x, y only for position_xy robots)",
)
def inverse_kinematics(body: IKRequest, name: str = RobotName) -> IKResponse:
    robot = registry.get(name)
    seed = None
    if body.seed is not None:
        if len(body.seed) != robot.dof:
            raise InputError(f"seed needs {robot.dof} values, one per joint", field=("seed",))
        seed = np.asarray(body.seed, dtype=float)
    T = body.pose.as_matrix()
    result = robot_ik.search(robot, T, seed)
    if not result.success:
        free = robot_ik.search(robot, T, seed, respect_limits=False)
        if free.success:
            result = free
        elif free.position_error <= 1e-6 and free.orientation_error <= 1e-6:
            lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
            j = int(np.argmax(np.maximum(lo - free.positions, free.positions - hi)))
            raise JointLimit(
                f"the pose is reachable only with joint '{robot.joint_names[j]}' outside its limits",
                joint=j,
                extra={"joint_name": robot.joint_names[j]},
            )
        else:
            raise Unreachable(
                f"no IK solution within 1e-6 m and 1e-6 rad (best residual "
                f"{result.position_error:.3g} m, {result.orientation_error:.3g} rad)",
                extra={
                    "position_error": result.position_error,
                    "orientation_error": result.orientation_error,
                },
            )
    return IKResponse(
        positions=result.positions.tolist(),
        position_error=result.position_error,
        orientation_error=result.orientation_error,
    )
