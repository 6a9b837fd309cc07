"""Link frames of ``Robot``: their names, poses, the frames for drawing the arm, and the reach.

Link frames are the model's BODY frames (the URDF's links); a tool frame (TCP offset) is an
operational frame of the model, not a link: it is where FK answers, never listed here.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from robots.robot_data import RobotData


class Frames(RobotData):
    """Link frames and the reach of the tool point."""

    def frame_pose(self, q: np.ndarray, frame: str) -> np.ndarray:
        """``T_base_frame`` (4, 4) of any link frame; ``UnknownFrame`` lists the frames."""
        fid = self._frame_id(frame)
        data = pin.Data(self._model)
        pin.forwardKinematics(self._model, data, self._q(q))
        return self._T_base_world @ pin.updateFramePlacement(self._model, data, fid).homogeneous

    def link_frames(self, q: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """Every link frame's name and ``T_base_frame`` (4, 4) at ``q``, in kinematic order (the
        model's frame order: each link after its parent)."""
        data = pin.Data(self._model)
        pin.framesForwardKinematics(self._model, data, self._q(q))
        return [
            (f.name, self._T_base_world @ data.oMf[i].homogeneous)
            for i, f in enumerate(self._model.frames)
            if f.type == pin.FrameType.BODY
        ]

    def reach_origin(self) -> np.ndarray:
        """A point on the first joint's axis (its origin) in the base frame [m]."""
        return np.array(self._chain.joint_axes_many(np.zeros((1, self._model.nq)))[1][0, 0])

    def reach_bound(self) -> float:
        """An upper bound [m] of the tool point's distance from ``reach_origin``: the sum of the
        distances between consecutive joint origins and from the last one to the tool point
        (prismatic joints add their largest extension)."""
        _, o, T = self._chain.joint_axes_many(np.zeros((1, self._model.nq)))
        pts = np.vstack([o[0], T[0, :3, 3]])
        travel = np.where(self._revolute, 0.0, np.abs(self._limits).max(axis=1)).sum()
        return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() + travel)

    def reach_distance(self, T_base_tool: np.ndarray) -> float:
        """The distance [m] of a tool pose's position from ``reach_origin``, to compare with
        ``reach_bound`` (in x and y only for a ``position_xy`` arm)."""
        axes = 2 if self._task_space == "position_xy" else 3
        offset = np.asarray(T_base_tool, dtype=float)[:3, 3] - self.reach_origin()
        return float(np.linalg.norm(offset[:axes]))
