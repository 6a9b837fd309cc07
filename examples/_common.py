"""Helpers of the example scripts: a client of a running service and independent checks.

The examples send their requests over HTTP to a running service (``--url``, default
``http://127.0.0.1:8000``, where the README's start command serves it), with nothing but the
standard library (``urllib``), and check what comes back against the robot's forward kinematics
(``robots``, installed with the service by ``pip install .``) and their own line geometry (scipy's
Slerp), not the service's. ``expect`` prints and exits with status 1 when a promise does not hold.
"""

from __future__ import annotations

import argparse
import json
import sys
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run from a checkout without installing: import its packages
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation, Slerp  # noqa: E402

from core.geometry.so3 import pose_to_matrix  # noqa: E402
from robots import registry  # noqa: E402

URL = "/v1/trajectories/cartesian"
DEFAULT_URL = "http://127.0.0.1:8000"
TIMEOUT_S = 120.0


class Response:
    """What the service answered: ``status_code``, ``text`` and ``json()``."""

    def __init__(self, status_code: int, body: bytes) -> None:
        self.status_code = status_code
        self.text = body.decode("utf-8", errors="replace")

    def json(self) -> Any:
        return json.loads(self.text)


class Client:
    """A minimal JSON client of the service at ``base_url`` (urllib, one request at a time)."""

    def __init__(self, base_url: str) -> None:
        self.base_url = base_url.rstrip("/")

    def get(self, path: str) -> Response:
        return self._send(urllib.request.Request(self.base_url + path))

    def post(self, path: str, json: Any) -> Response:
        body = _dumps(json)
        headers = {"content-type": "application/json"}
        return self._send(urllib.request.Request(self.base_url + path, body, headers))

    def _send(self, request: urllib.request.Request) -> Response:
        try:
            with urllib.request.urlopen(request, timeout=TIMEOUT_S) as answer:
                return Response(answer.status, answer.read())
        except urllib.error.HTTPError as error:  # 4xx and 5xx: problem+json bodies
            return Response(error.code, error.read())
        except urllib.error.URLError as error:
            print(
                f"no service at {self.base_url} ({error.reason}): start one with "
                "`python -m service --host 127.0.0.1 --port 8000` (see the README) or pass --url"
            )
            sys.exit(2)


def _dumps(value: Any) -> bytes:
    return json.dumps(value).encode()


def client() -> Client:
    """The client of the service at ``--url`` (default ``DEFAULT_URL``), from the command line."""
    parser = argparse.ArgumentParser(description=sys.modules["__main__"].__doc__)
    parser.add_argument("--url", default=DEFAULT_URL, help=f"the service (default {DEFAULT_URL})")
    return Client(parser.parse_args().url)


def expect(condition: object, message: str) -> None:
    """Exit with status 1 and say why when ``condition`` is false."""
    if not condition:
        print(f"FAILED: {message}")
        sys.exit(1)


def goal_matrix(request: dict[str, Any]) -> np.ndarray:
    robot = registry.get(request["robot"])
    goal = request["goal"]
    if "positions" in goal:
        return robot.fk(np.array(goal["positions"]))
    pose = goal["pose"]
    return pose_to_matrix(np.array(pose["position"]), np.array(pose["orientation"]))


def line_errors(request: dict[str, Any], positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] and orientation [rad] distance of the tool at each row of ``positions`` from
    the request's line (orientation against the slerp at the closest point's s)."""
    robot = registry.get(request["robot"])
    T0 = robot.fk(np.array(request["start"]["positions"]))
    T1 = goal_matrix(request)
    xy = robot.task_space == "position_xy"
    rows = slice(0, 2) if xy else slice(0, 3)
    T = robot.fk_many(positions)
    p0, d = T0[rows, 3], T1[rows, 3] - T0[rows, 3]
    s = np.clip((T[:, rows, 3] - p0) @ d / (d @ d), 0.0, 1.0)
    position = np.linalg.norm(T[:, rows, 3] - (p0 + s[:, None] * d), axis=1)
    if xy:
        return position, np.zeros(len(s))
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([T0[:3, :3], T1[:3, :3]])))
    orientation = (slerp(s).inv() * Rotation.from_matrix(T[:, :3, :3])).magnitude()
    return position, orientation


def points(body: dict[str, Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (N,), positions and velocities (N, dof) of a trajectory response."""
    pts = body["points"]
    return (
        np.array([p["time_from_start"] for p in pts]),
        np.array([p["positions"] for p in pts]),
        np.array([p["velocities"] for p in pts]),
    )


def check_trajectory(request: dict[str, Any], body: dict[str, Any], end_on_goal: bool) -> None:
    """Every point on the line (1e-6 m, 1e-6 rad), the last on the goal pose when ``end_on_goal``,
    joint speeds within the limits at every point, and no jump between points (a branch flip
    would move a joint farther than its speed limit allows in one sample period)."""
    robot = registry.get(request["robot"])
    times, q, v = points(body)
    pos, ori = line_errors(request, q)
    print(f"  {len(times)} points over {times[-1]:.3f} s; farthest from the line: "
          f"{pos.max():.2e} m, {ori.max():.2e} rad")  # fmt: skip
    expect(pos.max() <= 1e-6 and ori.max() <= 1e-6, "a returned point is off the line")
    if end_on_goal:
        T_end, T_goal = robot.fk(q[-1]), goal_matrix(request)
        rows = slice(0, 2) if robot.task_space == "position_xy" else slice(0, 3)
        expect(np.linalg.norm(T_end[rows, 3] - T_goal[rows, 3]) <= 1e-6, "the end misses the goal")
        if robot.task_space == "pose":
            angle = Rotation.from_matrix(T_end[:3, :3].T @ T_goal[:3, :3]).magnitude()
            expect(angle <= 1e-6, "the end orientation misses the goal")
    ratio = np.abs(v) / robot.velocity_limits
    print(f"  peak joint speed: {ratio.max():.1%} of the limit")
    expect(ratio.max() <= 1.0 + 1e-9, "a joint exceeds its velocity limit")
    step = np.abs(np.diff(q, axis=0)) / (robot.velocity_limits * np.diff(times)[:, None])
    expect(step.max() <= 1.05, "a joint jumps between two points (branch flip)")
    expect(np.all(np.abs(v[-1]) == 0.0), "the last point is not at rest")
