"""Planar 2-link arm (1.0 m and 0.8 m links): a line through the hole of the workspace (Type I).

The arm reaches 0.2 m <= r <= 1.8 m from its base. The line from (-0.8, 0.05) to (0.8, 0.05) passes
within 0.05 m of the base, so it enters the unreachable disc r < 0.2 m at
s = (0.8 - sqrt(0.2^2 - 0.05^2)) / 1.6 = 0.3790. The service answers 422 ``unreachable`` at that s,
and with ``allow_partial`` 200 with the prefix up to it (``fraction``). Run:
``python examples/planar_through_hole.py [--url URL]``.
"""

from __future__ import annotations

import math

from _common import URL, check_trajectory, client, expect

L1, L2 = 1.0, 0.8
START_XY, GOAL_XY = (-0.8, 0.05), (0.8, 0.05)
S_HOLE = (0.8 - math.sqrt(0.2**2 - 0.05**2)) / 1.6


def elbow_down(x: float, y: float) -> list[float]:
    """Closed-form IK of the planar arm, positive elbow angle: the service labels it `down`."""
    q2 = math.acos((x * x + y * y - L1 * L1 - L2 * L2) / (2 * L1 * L2))
    q1 = math.atan2(y, x) - math.atan2(L2 * math.sin(q2), L1 + L2 * math.cos(q2))
    return [q1, q2]


REQUEST = {
    "robot": "planar_2r",
    "start": {"positions": elbow_down(*START_XY)},
    "goal": {"pose": {"position": [*GOAL_XY, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0]}},
    "method": "sampled",
}


def main() -> None:
    c = client()
    print(f"the line enters the hole r < 0.2 m at s = {S_HOLE:.4f}")
    response = c.post(URL, json=REQUEST)
    expect(response.status_code == 422, f"expected 422, got {response.status_code}")
    problem = response.json()
    print(f"  without allow_partial: {response.status_code} {problem['code']} at s={problem['s']}: "
          f"{problem['detail']}")  # fmt: skip
    expect(problem["code"] == "unreachable", "the failure should be unreachable")
    expect(abs(problem["s"] - S_HOLE) <= 0.02, "unreachable at the wrong s")

    partial = {**REQUEST, "allow_partial": True}
    response = c.post(URL, json=partial)
    expect(
        response.status_code == 200, f"expected 200 with allow_partial, got {response.status_code}"
    )
    body = response.json()
    diag = body["diagnostics"]
    print(f"  with allow_partial: fraction {diag['fraction']:.4f}, failure {diag['failure']['code']} "
          f"at s={diag['failure']['s']}")  # fmt: skip
    expect(abs(diag["fraction"] - S_HOLE) <= 0.02, "fraction should be where the hole starts")
    expect(diag["fraction"] <= problem["s"], "the prefix must stop before the failure")
    expect(diag["failure"]["code"] == "unreachable", "diagnostics.failure should say unreachable")
    check_trajectory(partial, body, end_on_goal=False)
    print("OK")


if __name__ == "__main__":
    main()
