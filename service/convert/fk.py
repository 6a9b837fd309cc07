"""Forward kinematics of many rows of joint positions: ``POST /v1/robots/{name}/fk`` (and
``POST /v1/fk``) with ``"positions": [[...], ...]``.

Each row's answer is what the single form answers for that row (``pose``, ``jacobian``,
``min_singular_value``, ``manipulability``, ``configuration``, ``frames``), computed with the same
robot methods; what vectorizes is done once for every row: the configuration labels
(``Robot.configurations``) and the quaternions of every pose and link frame
(``core.geometry.so3.matrix_to_quat`` on the stacked rotations, row by row the same arithmetic).
The rows are checked (length, position limits) before any is computed, so a bad row is named
(``positions.<row>``, ``positions.<row>.<joint>``) without partial work.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from core.budget import Deadline
from core.geometry.so3 import matrix_to_quat
from robots.model import Robot
from service.convert.robot import robot_positions


def fk_rows(
    robot: Robot,
    rows: Sequence[Sequence[float]],
    frame: str | None,
    frames: bool,
    deadline: Deadline,
) -> list[dict[str, Any]]:
    """One single-form FK answer (a JSON-ready dict) per row of ``rows`` [rad or m] of ``robot``
    (its tool offset applied): the pose of ``frame`` (default the tool frame), with every link
    frame when ``frames``. ``deadline`` is checked between rows."""
    qs = np.array([robot_positions(robot, q, ("positions", k)) for k, q in enumerate(rows)])
    poses, jacobians, sigmas, links = [], [], [], []
    names: list[str] = []
    for q in qs:
        deadline.check("forward kinematics")
        if frame is None:
            T, J = robot.fk(q), robot.jacobian(q)
        else:
            T, J = robot.frame_pose(q, frame), robot.jacobian(q, frame)
        poses.append(T)
        jacobians.append(J)
        sigmas.append(robot.singular_values(q, J))
        if frames:
            named = robot.link_frames(q)
            names = [name for name, _ in named]
            links.append([F for _, F in named])
    labels = robot.configurations(qs)
    quats = matrix_to_quat(np.array(poses)[:, :3, :3]).tolist()
    link_quats = matrix_to_quat(np.array(links)[..., :3, :3]).tolist() if frames else []
    out = []
    for k, T in enumerate(poses):
        frame_list = None
        if frames:
            frame_list = [
                {"name": name, "position": F[:3, 3].tolist(), "orientation": link_quats[k][i]}
                for i, (name, F) in enumerate(zip(names, links[k], strict=True))
            ]
        out.append(
            {
                "pose": {"position": T[:3, 3].tolist(), "orientation": quats[k]},
                "jacobian": jacobians[k].tolist(),
                "min_singular_value": float(sigmas[k][-1]),
                "manipulability": float(np.prod(sigmas[k])),
                "configuration": labels[k],
                "frames": frame_list,
            }
        )
    return out
