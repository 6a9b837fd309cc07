"""UR5: a straight line with a rotation of the tool, planned by sampled IK.

Every returned point is on the line (within 1e-6 m and 1e-6 rad, checked here with the robot's own
forward kinematics), the last point is on the goal pose, joint speeds stay within the limits and no
joint jumps. Run: ``python examples/ur5_line.py [--url URL]`` (exit status 0 when all of that holds).
"""

from __future__ import annotations

import math

from _common import URL, check_trajectory, client, expect

HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
REQUEST = {
    "robot": "ur5",
    "start": {"positions": HOME},
    # 23 cm across, the tool turned by 0.29 rad.
    "goal": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]},
    "method": "sampled",
    "max_linear_speed": 0.2,
    "max_angular_speed": 0.8,
}


def main() -> None:
    response = client().post(URL, json=REQUEST)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    diag = body["diagnostics"]
    print(f"ur5 line: fraction {diag['fraction']}, deviation between points "
          f"{diag['max_position_deviation']:.2e} m / {diag['max_orientation_deviation']:.2e} rad, "
          f"smallest singular value {diag['min_singular_value']:.3f}")  # fmt: skip
    check_trajectory(REQUEST, body, end_on_goal=True)
    expect(diag["fraction"] == 1.0, "the whole line should be planned")
    expect(
        body["points"][-1]["positions"] == REQUEST["goal"]["positions"], "ends off goal.positions"
    )
    print("OK")


if __name__ == "__main__":
    main()
