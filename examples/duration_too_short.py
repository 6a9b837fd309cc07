"""A duration too short for the joints is 422 ``joint_rate_limit``; speed limits plan the same line.

With a fixed ``duration`` the planner never stretches time: when a joint would exceed its velocity
limit the answer is 422 ``joint_rate_limit`` with the s where it first happens and the shortest
duration that works (``min_duration``). The same line under tool speed limits is planned within the
joint limits, and so is the line with ``duration = min_duration``. Run:
``python examples/duration_too_short.py [--url URL]``.
"""

from __future__ import annotations

import math

from _common import URL, check_trajectory, client, expect

HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
LINE = {
    "robot": "ur5",
    "start": {"positions": HOME},
    "goal": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]},
    "method": "sampled",
}


def main() -> None:
    c = client()
    response = c.post(URL, json={**LINE, "duration": 0.1})
    problem = response.json()
    print(f"duration 0.1 s: {response.status_code} {problem.get('code')} at s={problem.get('s')}: "
          f"{problem.get('detail')}")  # fmt: skip
    expect(response.status_code == 422 and problem["code"] == "joint_rate_limit", "expected 422")
    expect(0.0 < problem["s"] < 1.0, "the problem carries the s of the first excess")
    min_duration = problem["min_duration"]

    for name, request in (
        ("speed limits", {**LINE, "max_linear_speed": 1.0, "max_angular_speed": 3.0}),
        (f"duration {min_duration * 1.001:.4f} s", {**LINE, "duration": min_duration * 1.001}),
    ):
        response = c.post(URL, json=request)
        expect(response.status_code == 200, f"{name}: expected 200, got {response.text}")
        body = response.json()
        print(f"{name}: 200, duration {body['diagnostics']['duration']:.3f} s, warnings "
              f"{body['diagnostics']['warnings']}")  # fmt: skip
        check_trajectory(request, body, end_on_goal=True)
    print("OK")


if __name__ == "__main__":
    main()
