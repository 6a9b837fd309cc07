"""A piece of a program's joint path: a segment's own part or the blend out of it, as samples."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Piece:
    """A segment's own part (``blend`` False) or the blend out of it, as joint samples.

    Attributes:
        owner: The segment's index in the request.
        blend: Whether this is the blend out of ``owner``.
        q: Joint samples (K, dof); the first is the previous piece's last in the chunk.
        T: Tool poses at them (K, 4, 4).
        scales: Velocity and acceleration scale of the joint limits.
        tool_speed: Linear and angular tool speed limits [m/s, rad/s] (inf: none).
        tool_acc: Linear and angular tool acceleration limits [m/s^2, rad/s^2] (inf: none).
        s: Path parameter of the owner at each sample (K,) (its own part), None for a blend.
        times: (start, end) [s], in the chunk once timed, in the program once placed.
        knots: Time [s] in the chunk of each sample (K,), once timed (None: a profiled PTP).
    """

    owner: int
    blend: bool
    q: np.ndarray
    T: np.ndarray
    scales: tuple[float, float]
    tool_speed: tuple[float, float]
    tool_acc: tuple[float, float]
    s: np.ndarray | None = None
    times: tuple[float, float] = (0.0, 0.0)
    knots: np.ndarray | None = None
