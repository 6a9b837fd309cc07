"""UR5: Taylor's bounded deviation (course notes §7.1) on a 0.3 m line with a 30 degree turn.

Knots in joint space, refined by the recursive midpoint test until joint interpolation between them
stays within 1 mm and 0.01 rad of the line; the trajectory is a C2 spline through the knots, and
the service measures it densely and splits again wherever it still strays. This script checks the
promise itself: between every two returned points, joints interpolated linearly at 12 points, FK
by the robot, distance to the line at most the tolerance. Run: ``python
examples/ur5_bounded_deviation.py [--url URL]`` (exit status 0 when all of that holds).
"""

from __future__ import annotations

import math

import numpy as np
from _common import (
    URL,
    client,
    expect,
    goal_matrix,
    line_errors,
    points,
)  # puts the repo on the path
from scipy.spatial.transform import Rotation

from core.geometry.so3 import matrix_to_quat
from robots import registry

HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
TOLERANCE = {"position": 1e-3, "orientation": 1e-2}


def goal_pose() -> dict[str, list[float]]:
    """The tool 0.3 m away along (2, 1.5, -1.5) and turned 30 degrees about (1, 1, 0)."""
    T0 = registry.get("ur5").fk(np.array(HOME))
    direction = np.array([0.2, 0.15, -0.15])
    position = T0[:3, 3] + 0.3 * direction / np.linalg.norm(direction)
    turn = Rotation.from_rotvec(np.radians(30) * np.array([1.0, 1.0, 0.0]) / math.sqrt(2))
    R = turn.as_matrix() @ T0[:3, :3]
    return {"position": position.tolist(), "orientation": matrix_to_quat(R).tolist()}


def request(method: str) -> dict:
    return {
        "robot": "ur5",
        "start": {"positions": HOME},
        "goal": {"pose": goal_pose()},
        "method": method,
        "tolerance": TOLERANCE,
        "max_linear_speed": 0.25,
        "max_angular_speed": 1.0,
    }


def check_between_points(req: dict, body: dict, checks: int = 12) -> tuple[float, float]:
    """Largest deviation [m], [rad] of the tool with joints interpolated linearly between points."""
    times, q, _ = points(body)
    frac = np.arange(checks + 1) / (checks + 1)
    dense = np.append((times[:-1, None] + frac * np.diff(times)[:, None]).ravel(), times[-1])
    q_dense = np.array([np.interp(dense, times, col) for col in q.T]).T
    pos, ori = line_errors(req, q_dense)
    return float(pos.max()), float(ori.max())


def check_plan(req: dict, body: dict) -> None:
    robot = registry.get("ur5")
    diag = body["diagnostics"]
    times, q, v = points(body)
    pos, ori = check_between_points(req, body)
    print(f"  {diag['knot_count']} knots, {len(times)} points over {times[-1]:.2f} s; between the "
          f"points the tool stays within {pos:.2e} m and {ori:.2e} rad of the line "
          f"(service: {diag['max_position_deviation']:.2e} m, "
          f"{diag['max_orientation_deviation']:.2e} rad)")  # fmt: skip
    expect(pos <= TOLERANCE["position"], "the tool strays more than 1 mm from the line")
    expect(ori <= TOLERANCE["orientation"], "the tool turns more than 0.01 rad off the line")
    expect(len(body["knots"]) == diag["knot_count"], "knots and knot_count disagree")
    T_end, T_goal = robot.fk(q[-1]), goal_matrix(req)
    expect(np.linalg.norm(T_end[:3, 3] - T_goal[:3, 3]) <= 1e-6, "the end misses the goal")
    expect(
        np.all(np.abs(v) <= robot.velocity_limits * (1 + 1e-9)), "a joint exceeds its speed limit"
    )
    expect(np.all(np.asarray(v[-1]) == 0.0), "the last point is not at rest")
    lo, hi = robot.position_limits.T
    expect(np.all((q >= lo) & (q <= hi)), "a joint leaves its limits")


def main() -> None:
    req = request("bounded_deviation")
    response = client().post(URL, json=req)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    diag = body["diagnostics"]
    print(f"ur5 bounded_deviation: {diag['midpoint_tests']} midpoint tests, recursion depth "
          f"{diag['max_recursion_depth']}, {diag['resplits']} segments split after measuring")  # fmt: skip
    check_plan(req, body)
    print("OK")


if __name__ == "__main__":
    main()
