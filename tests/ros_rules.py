"""The rules of the ROS 2 joint trajectory controller that every trajectory response must pass.

One reusable checker for every endpoint's tests (API.md, "Trajectories"):

- ``joint_names``: non-empty, unique, non-empty strings;
- every point: ``time_from_start``, ``positions``, ``velocities``, ``accelerations`` (no ``effort``,
  nothing else), one value per joint in every array, every number finite;
- times: start at 0, strictly increasing (also after the conversion to integer nanoseconds), the
  last equals ``diagnostics.duration``; with ``?time_format=ros`` each is ``{"sec", "nanosec"}``
  with integer fields and ``0 <= nanosec < 1e9``;
- a rest-to-rest plan ends with zero velocity: the controller (with the default
  ``allow_nonzero_velocity_at_trajectory_end: false``) rejects ``|v| > DBL_EPSILON``;
- diagnostics: ``peak_velocity``/``peak_acceleration`` one finite value per joint.

``check_ros_trajectory`` raises ``AssertionError`` with a message naming the rule and returns the
parsed arrays for further checks.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

POINT_KEYS = {"time_from_start", "positions", "velocities", "accelerations"}
DBL_EPSILON = float(np.finfo(float).eps)


class Parsed(NamedTuple):
    """A checked response as arrays: times [s] ``(N,)``, times in integer ns ``(N,)``, and
    positions/velocities/accelerations ``(N, dof)``."""

    times: np.ndarray
    times_ns: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    joint_names: list[str]
    diagnostics: dict[str, Any]


def _finite_numbers(values: Any, what: str) -> None:
    assert isinstance(values, list), f"{what} is not a list"
    assert {type(v) for v in values} <= {float, int}, f"{what} holds a non-numeric value"
    assert np.all(np.isfinite(np.array(values, dtype=float))), f"{what} holds a non-finite value"


def _time_ns(value: Any, time_format: str, i: int) -> int:
    if time_format == "ros":
        assert isinstance(value, dict) and set(value) == {"sec", "nanosec"}, (
            f"point {i}: time_from_start is not a ROS Duration {{sec, nanosec}}"
        )
        sec, nanosec = value["sec"], value["nanosec"]
        assert isinstance(sec, int) and isinstance(nanosec, int), f"point {i}: non-integer Duration"
        assert not isinstance(sec, bool) and not isinstance(nanosec, bool)
        assert 0 <= nanosec < 1_000_000_000, f"point {i}: nanosec out of [0, 1e9)"
        assert sec >= 0, f"point {i}: negative sec"
        return sec * 1_000_000_000 + nanosec
    assert isinstance(value, float) and math.isfinite(value), f"point {i}: time is not a float"
    return round(value * 1e9)


def check_ros_trajectory(
    body: dict[str, Any], *, rest_to_rest: bool, time_format: str = "float"
) -> Parsed:
    """Assert every rule above on a trajectory response ``body`` (parsed JSON)."""
    names = body.get("joint_names")
    assert isinstance(names, list) and names, "joint_names is empty"
    assert all(isinstance(n, str) and n for n in names), "a joint name is empty"
    assert len(set(names)) == len(names), "joint names are not unique"
    dof = len(names)
    points = body.get("points")
    assert isinstance(points, list) and len(points) >= 2, "fewer than 2 points"
    arrays: dict[str, list[list[float]]] = {"positions": [], "velocities": [], "accelerations": []}
    times_ns, times, types = [], [], set()
    for i, point in enumerate(points):
        assert "effort" not in point, f"point {i} has effort"
        assert set(point) == POINT_KEYS, f"point {i} keys {sorted(point)} != {sorted(POINT_KEYS)}"
        for key, rows in arrays.items():
            values = point[key]
            assert isinstance(values, list), f"point {i}: {key} is not a list"
            assert len(values) == dof, f"point {i}: {len(values)} {key} for {dof} joints"
            types.update(map(type, values))
            rows.append(values)
        t = point["time_from_start"]
        times_ns.append(_time_ns(t, time_format, i))
        times.append(t if time_format == "float" else times_ns[-1] * 1e-9)
    assert types <= {float, int}, "a point holds a non-numeric value (null, string, bool)"
    for key, rows in arrays.items():
        assert np.all(np.isfinite(np.array(rows, dtype=float))), f"a non-finite value in {key}"
    ns = np.array(times_ns, dtype=np.int64)
    assert ns[0] == 0, "the first point is not at time 0"
    if time_format == "float":
        assert times[0] == 0.0, "the first time is not exactly 0.0"
        assert np.all(np.diff(times) > 0), "times are not strictly increasing"
    assert np.all(np.diff(ns) > 0), "times are not strictly increasing in integer nanoseconds"
    diagnostics = body.get("diagnostics")
    assert isinstance(diagnostics, dict), "no diagnostics"
    duration = diagnostics["duration"]
    assert isinstance(duration, float) and math.isfinite(duration) and duration > 0
    if time_format == "float":
        assert times[-1] == duration, "the last point is not at the duration"
    else:
        assert ns[-1] == round(duration * 1e9), "the last point is not at the duration"
    for key in ("peak_velocity", "peak_acceleration"):
        _finite_numbers(diagnostics[key], f"diagnostics.{key}")
        assert len(diagnostics[key]) == dof, f"diagnostics.{key} has the wrong length"
    velocities = np.array(arrays["velocities"])
    if rest_to_rest:
        assert np.all(np.abs(velocities[-1]) <= DBL_EPSILON), "non-zero velocity at the last point"
    return Parsed(
        times=np.array(times, dtype=float),
        times_ns=ns,
        positions=np.array(arrays["positions"]),
        velocities=velocities,
        accelerations=np.array(arrays["accelerations"]),
        joint_names=names,
        diagnostics=diagnostics,
    )
