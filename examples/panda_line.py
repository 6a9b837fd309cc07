"""Panda (7 joints, redundant): a straight line with a rotation of the tool, by sampled IK.

The goal is a pose; IK at each point is seeded where the Jacobian's pseudo-inverse predicts, so the
arm's null-space motion stays smooth. Checks as in ``ur5_line.py``. Run:
``python examples/panda_line.py [--url URL]``.
"""

from __future__ import annotations

import math

from _common import URL, check_trajectory, client, expect

HOME = [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4]
REQUEST = {
    "robot": "panda",
    "start": {"positions": HOME},
    # From (0.307, 0, 0.590): 20 cm forward, 15 cm left, 20 cm down; the hand turned by 0.5 rad
    # (0.3 rad about base x, then 0.4 rad about base z, from its "ready" orientation).
    "goal": {
        "pose": {
            "position": [0.507, 0.15, 0.39],
            "orientation": [0.97047, -0.189358, -0.083476, -0.123949],
        }
    },
    "method": "sampled",
    "samples": 200,
}


def main() -> None:
    response = client().post(URL, json=REQUEST)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    diag = body["diagnostics"]
    print(f"panda line: fraction {diag['fraction']}, {len(body['points'])} points, deviation "
          f"between points {diag['max_position_deviation']:.2e} m / "
          f"{diag['max_orientation_deviation']:.2e} rad")  # fmt: skip
    check_trajectory(REQUEST, body, end_on_goal=True)
    expect(len(body["points"]) == 200, "samples=200 should give 200 points")
    print("OK")


if __name__ == "__main__":
    main()
