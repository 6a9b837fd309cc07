"""The ROS-shaped ``points`` of a trajectory written as one JSON fragment, straight from numpy.

``trajectory_points`` builds a dict and three row views per sample for orjson to walk; here each
array is encoded once by orjson (``OPT_SERIALIZE_NUMPY``, the same float text it writes for a row
view or a Python float), split into its rows, and the rows are interleaved with the constant framing
of a point by list slicing: no Python object per number and no Python loop per sample. The bytes
are exactly those of ``orjson.dumps(trajectory_points(traj, time_format))`` (tested).

``PointsJSON`` stands in a response document where ``points`` goes: it has the samples' count
(``len``) for the admission in ``service.encoding``, and ``orjson.dumps(..., default=encode_default)``
writes it as the fragment (or a chunk of it at a time when streamed).
"""

from __future__ import annotations

import numpy as np
import orjson

from core.trajectory import Trajectory, check_duration

_NUMPY = orjson.OPT_SERIALIZE_NUMPY
_ROWS = (b',"positions":[', b'],"velocities":[', b'],"accelerations":[')
_NEXT = b']},{"time_from_start":'
"""Closes a point and opens the next one; the first point opens with ``_NEXT[3:]``."""


def ros_parts(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times ``(n,)`` [s] -> ROS Duration ``sec`` and ``nanosec`` ``(n,)`` int64 arrays, through
    integer nanoseconds (``nanosec`` in [0, 1e9)).

    Times outside ``[0, MAX_DURATION]`` are refused first (``check_duration``, 422 ``infeasible``):
    the int64 nanoseconds cannot overflow (from 9.2e9 s they wrapped to negative seconds), and
    strictly increasing times at least a nanosecond apart stay strictly increasing."""
    t = np.asarray(times, dtype=np.float64)
    if t.size:
        check_duration(float(t.max()))
        check_duration(float(t.min()))
    return np.divmod(np.rint(t * 1e9).astype(np.int64), 1_000_000_000)


def _items(values: np.ndarray) -> list[bytes]:
    """orjson's text of each value of a 1-D array (float64 or int64)."""
    return orjson.dumps(values, option=_NUMPY)[1:-1].split(b",")


def _rows(values: np.ndarray) -> list[bytes]:
    """orjson's text of each row of a 2-D float64 array, without its brackets."""
    text = orjson.dumps(np.ascontiguousarray(values, dtype=np.float64), option=_NUMPY)
    return text[2:-2].split(b"],[")


def points_json(
    traj: Trajectory, time_format: str = "float", start: int = 0, stop: int | None = None
) -> bytes:
    """``orjson.dumps(trajectory_points(traj, time_format)[start:stop])``, written from the arrays.

    Args:
        time_format: ``float`` (seconds) or ``ros`` (``{"sec", "nanosec"}`` through integer
            nanoseconds, as ``ros_durations``).
        start, stop: The samples to write, as a slice.
    """
    part = slice(start, stop)
    times = np.ascontiguousarray(traj.times[part], dtype=np.float64)
    n = times.size
    if n == 0:
        return b"[]"
    if time_format == "ros":
        sec, nanosec = ros_parts(times)
        slots: list = [_NEXT + b'{"sec":', _items(sec), b',"nanosec":', _items(nanosec), b"}"]
    else:
        slots = [_NEXT, _items(times)]
    arrays = (traj.positions, traj.velocities, traj.accelerations)
    for frame, values in zip(_ROWS, arrays, strict=True):
        slots += [frame, _rows(values[part])]
    width = len(slots)
    # One point's framing repeated n times, then each varying slot filled by a strided slice.
    parts: list = [s if isinstance(s, bytes) else b"" for s in slots] * n
    for k, slot in enumerate(slots):
        if not isinstance(slot, bytes):
            parts[k::width] = slot
    parts[0] = parts[0][len(b"]},") :]
    return b"[" + b"".join(parts) + b"]}]"


class PointsJSON:
    """The ``points`` of a response document, encoded when the document is (``encode_default``).

    Attributes:
        trajectory: The sampled trajectory.
        time_format: ``float`` or ``ros``.
    """

    __slots__ = ("time_format", "trajectory")

    def __init__(self, trajectory: Trajectory, time_format: str = "float") -> None:
        self.trajectory = trajectory
        self.time_format = time_format

    def __len__(self) -> int:
        return int(self.trajectory.times.size)

    @property
    def dof(self) -> int:
        return self.trajectory.dof

    def encode(self, start: int = 0, stop: int | None = None) -> bytes:
        """The JSON array of the points ``[start:stop]``."""
        return points_json(self.trajectory, self.time_format, start, stop)


def encode_default(obj: object) -> orjson.Fragment:
    """orjson's ``default``: a ``PointsJSON`` as its encoded fragment; anything else unsupported."""
    if isinstance(obj, PointsJSON):
        return orjson.Fragment(obj.encode())
    raise TypeError(f"{type(obj).__name__} is not JSON serializable")
