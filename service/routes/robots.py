"""/v1/robots: the registered robots, their limits, forward and inverse kinematics (every IK
solution, configuration labels), and the same for inline robots (POST /v1/fk, /v1/ik,
/v1/robots/describe with ``robot`` in the body: a registered name or an inline URDF model)."""

from __future__ import annotations

from typing import cast

import numpy as np
from fastapi import APIRouter, Depends, Path
from starlette.responses import Response

from core.budget import Deadline
from core.errors import InputError, JointLimit, Unreachable
from core.limits import worst_joint
from robots import ik as robot_ik
from robots import registry
from robots.collision import link_shapes, robot_setup
from robots.model import Robot
from service import deps
from service.convert.environment import inline_urdf
from service.convert.fk import fk_rows
from service.convert.robot import robot_positions, with_tool
from service.encoding import json_response
from service.schemas.common import PROBLEM_RESPONSES, Pose
from service.schemas.robots import (
    NAME_PATTERN,
    CollisionShape,
    DescribeRequest,
    FKBatchResponse,
    FKRequest,
    FKResponse,
    IKAllResponse,
    IKInfo,
    IKRequest,
    IKResponse,
    IKSolutionOut,
    InlineFKRequest,
    InlineIKRequest,
    LinkFrame,
    RobotDetail,
    RobotLimits,
    RobotSummary,
)

router = APIRouter(tags=["robots"])
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


@router.get("/v1/robots", response_model=list[RobotSummary], summary="Registered robots")
def list_robots() -> list[dict]:
    return [_summary(registry.get(name)) for name in registry.names()]


def _collision(robot: Robot, urdf: str | None) -> dict:
    """``collision_geometry`` (the shapes as the check uses them) and ``allowed_self_collisions``
    (``robots.collision``)."""
    geometry, allowed = robot_setup(robot, urdf)
    shapes = [
        CollisionShape.model_validate(
            {"link": link, "shape": shape, "origin": Pose.from_matrix(T).model_dump()}
        )
        for link, shape, T in link_shapes(robot, geometry)
    ]
    return {
        "collision_geometry": shapes,
        "allowed_self_collisions": sorted(sorted(p) for p in allowed),
    }


def _detail(robot: Robot, urdf: str | None = None) -> RobotDetail:
    return RobotDetail(
        **_summary(robot),
        limits=RobotLimits(
            position=robot.position_limits.tolist(),
            velocity=robot.velocity_limits.tolist(),
            acceleration=robot.acceleration_limits.tolist(),
            jerk=None if robot.jerk_limits is None else robot.jerk_limits.tolist(),
            effort=None if robot.effort_limits is None else robot.effort_limits.tolist(),
        ),
        dynamics=robot.dynamics is not None,
        home=robot.home.tolist(),
        limit_sources=dict(robot.sources),
        ik=IKInfo(
            solver=robot.ik_solver,  # type: ignore[arg-type]
            max_solutions=robot.max_solutions,
            redundant_joints=list(robot.redundant_joints),
        ),
        configurations=list(robot.configuration_labels),
        **_collision(robot, urdf),
    )


# Registered before GET /v1/robots/{name}: the first route matching a path sets the Allow header of a
# 405, and "describe" would otherwise match {name}.
@router.post(
    "/v1/robots/describe",
    response_model=RobotDetail,
    responses=PROBLEM_RESPONSES,
    summary="The description of any robot, inline URDF models included",
)
def describe_robot(body: DescribeRequest) -> RobotDetail:
    robot = with_tool(registry.resolve(body.robot), body.tool)
    return _detail(robot, inline_urdf(body.robot))


@router.get(
    "/v1/robots/{name}",
    response_model=RobotDetail,
    responses=PROBLEM_RESPONSES,
    summary="One robot, with limits, its IK solver and configuration labels",
)
def get_robot(name: str = RobotName) -> RobotDetail:
    return _detail(registry.get(name))


def _fk(robot: Robot, body: FKRequest, deadline: Deadline) -> FKResponse | Response:
    robot = with_tool(robot, body.tool)
    if isinstance(body.positions[0], list):  # many rows: one answer each (service.convert.fk)
        rows = cast(list[list[float]], body.positions)
        return json_response({"results": fk_rows(robot, rows, body.frame, body.frames, deadline)})
    q = robot_positions(robot, cast(list[float], body.positions), ("positions",))
    if body.frame is None:
        T, J = robot.fk(q), robot.jacobian(q)
    else:
        T, J = robot.frame_pose(q, body.frame), robot.jacobian(q, body.frame)
    s = robot.singular_values(q, J)
    frames = None
    if body.frames:
        frames = []
        for name, F in robot.link_frames(q):
            pose = Pose.from_matrix(F)
            frames.append(
                LinkFrame(name=name, position=pose.position, orientation=pose.orientation)
            )
    return FKResponse(
        pose=Pose.from_matrix(T),
        jacobian=J.tolist(),
        min_singular_value=float(s[-1]),
        manipulability=float(np.prod(s)),
        configuration=robot.configuration(q),
        frames=frames,
    )


@router.post(
    "/v1/robots/{name}/fk",
    response_model=FKResponse | FKBatchResponse,
    responses=PROBLEM_RESPONSES,
    summary="Forward kinematics of one or many joint positions: pose, Jacobian, singular values, "
    "configuration label",
)
def forward_kinematics(
    body: FKRequest,
    name: str = RobotName,
    deadline: Deadline = Depends(deps.request_deadline),
) -> FKResponse | Response:
    return _fk(registry.get(name), body, deadline)


@router.post(
    "/v1/fk",
    response_model=FKResponse | FKBatchResponse,
    responses=PROBLEM_RESPONSES,
    summary="Forward kinematics of any robot (registered name or inline URDF in the body)",
)
def forward_kinematics_inline(
    body: InlineFKRequest, deadline: Deadline = Depends(deps.request_deadline)
) -> FKResponse | Response:
    return _fk(registry.resolve(body.robot), body, deadline)


def _ik(robot: Robot, body: IKRequest, deadline: Deadline) -> IKResponse | IKAllResponse:
    robot = with_tool(robot, body.tool)
    seed = None
    if body.seed is not None:
        if len(body.seed) != robot.dof:
            raise InputError(f"seed needs {robot.dof} values, one per joint", field=("seed",))
        lo, hi = robot.position_limits[:, 0], robot.position_limits[:, 1]
        seed = np.clip(np.asarray(body.seed, dtype=float), lo, hi)
    labels = robot.configuration_labels
    if body.configuration is not None and body.configuration not in labels:
        raise InputError(
            f"unknown configuration label; {robot.name} has "
            + (", ".join(labels) if labels else "no configuration labels"),
            field=("configuration",),
            extra={"configurations": list(labels)},
        )
    T = body.pose.as_matrix()
    if body.all:
        found = robot.ik_all(T, seed, body.fixed_joints, turns=body.turns)
    else:  # one solution: a second effort before "unreachable" (robots.ik_retry)
        found = robot.ik_one(T, seed, body.fixed_joints, body.configuration, deadline)
    keep = [
        k
        for k, label in enumerate(found.configurations)
        if body.configuration is None or label == body.configuration
    ]
    if not keep:
        _no_solution(robot, T, seed, found, body.configuration)
    solver = found.solver
    if body.all:
        return IKAllResponse(
            solutions=[
                IKSolutionOut(
                    positions=found.positions[k].tolist(),
                    configuration=found.configurations[k],
                    position_error=float(found.position_errors[k]),
                    orientation_error=float(found.orientation_errors[k]),
                )
                for k in keep
            ],
            solver=solver,  # type: ignore[arg-type]
            warnings=list(found.warnings),
        )
    k = keep[0]
    return IKResponse(
        positions=found.positions[k].tolist(),
        position_error=float(found.position_errors[k]),
        orientation_error=float(found.orientation_errors[k]),
        configuration=found.configurations[k],
        solver=solver,  # type: ignore[arg-type]
        warnings=list(found.warnings),
    )


def _no_solution(
    robot: Robot,
    T: np.ndarray,
    seed: np.ndarray | None,
    found: robot_ik.IKSolutions,
    configuration: str | None,
) -> None:
    """Raise the 422 that says why no solution is returned: other labels only, limits, or reach."""
    if len(found):
        existing = sorted({c for c in found.configurations if c is not None})
        raise Unreachable(
            "no IK solution with that configuration; this pose has " + ", ".join(existing),
            field=("configuration",),
            extra={"configurations": existing},
        )
    result = robot_ik.search(robot, T, seed)
    if result.success and robot.redundant_joints:  # solved with every joint free
        held = list(robot.redundant_joints)
        raise Unreachable(
            f"no solution with the redundant joints ({', '.join(held)}) held at fixed_joints or "
            "the seed's values; the pose is reachable with them elsewhere (all: false releases "
            "those fixed_joints does not name)",
            extra={"redundant_joints": held},
        )
    free = robot_ik.search(robot, T, seed, respect_limits=False)
    if found.outside_limits or (free.position_error <= 1e-6 and free.orientation_error <= 1e-6):
        j = worst_joint(free.positions, robot.position_limits)
        raise JointLimit(
            f"the pose is reachable only with joint '{robot.joint_names[j]}' outside its limits",
            joint=j,
            extra={"joint_name": robot.joint_names[j]},
        )
    reach = robot.reach_bound()
    distance = robot.reach_distance(T)  # planar arms: the distance in x, y
    raise Unreachable(
        f"no IK solution within 1e-9 m and 1e-9 rad (best residual {result.position_error:.3g} m, "
        f"{result.orientation_error:.3g} rad); the goal is {distance:.3g} m from the first joint, "
        f"the arm reaches at most {reach:.3g} m",
        extra={
            "position_error": result.position_error,
            "orientation_error": result.orientation_error,
            "reach": reach,
            "distance": distance,
        },
    )


@router.post(
    "/v1/robots/{name}/ik",
    response_model=IKResponse | IKAllResponse,
    responses=PROBLEM_RESPONSES,
    summary="Inverse kinematics of the tool pose: one solution or every one (all: true)",
)
def inverse_kinematics(
    body: IKRequest, name: str = RobotName, deadline: Deadline = Depends(deps.request_deadline)
) -> IKResponse | IKAllResponse:
    return _ik(registry.get(name), body, deadline)


@router.post(
    "/v1/ik",
    response_model=IKResponse | IKAllResponse,
    responses=PROBLEM_RESPONSES,
    summary="Inverse kinematics of any robot (registered name or inline URDF in the body)",
)
def inverse_kinematics_inline(
    body: InlineIKRequest, deadline: Deadline = Depends(deps.request_deadline)
) -> IKResponse | IKAllResponse:
    return _ik(registry.resolve(body.robot), body, deadline)
