"""PUMA 560: lines whose IK passes the wrist singularity (q5 = 0), a Type II problem.

At q5 = 0 joints 4 and 6 line up and the Jacobian loses rank. Two lines:

1. From q5 = 0.3 to the pose of q5 = -0.3 (joints 4 and 6 at 0): the IK branch goes straight
   through q5 = 0; the service reports ``singularity`` with the s where the smallest singular value
   of the Jacobian drops below its threshold (1e-3).
2. From (q4, q5, q6) = (0.4, 0.1, -0.4) to the pose of (-0.4, -0.1, 0.4): the line passes near the
   singularity, where the wrist has to turn fast (q4 and q6 turn by about pi). The service slows the
   tool down there, says so in a warning, and every joint stays within its velocity limit.

Run: ``python examples/puma_wrist_singularity.py [--url URL]``.
"""

from __future__ import annotations

import math

from _common import URL, check_trajectory, client, expect

Q2, Q3 = math.pi / 4, -math.pi
THROUGH = {
    "robot": "puma560",
    "start": {"positions": [0.0, Q2, Q3, 0.0, 0.3, 0.0]},
    "goal": {"positions": [0.0, Q2, Q3, 0.0, -0.3, 0.0]},
    "method": "sampled",
}
NEAR = {
    "robot": "puma560",
    "start": {"positions": [0.0, Q2, Q3, 0.4, 0.1, -0.4]},
    "goal": {"positions": [0.05, Q2, Q3, -0.4, -0.1, 0.4]},
    "method": "sampled",
}


def main() -> None:
    c = client()
    response = c.post(URL, json=THROUGH)
    problem = response.json()
    print(f"through q5 = 0: {response.status_code} {problem.get('code')} at s={problem.get('s')}: "
          f"{problem.get('detail')}")  # fmt: skip
    expect(response.status_code == 422 and problem["code"] == "singularity", "expected singularity")
    expect(0.4 < problem["s"] < 0.6, "the singularity is near the middle of the line")

    response = c.post(URL, json=NEAR)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    diag = body["diagnostics"]
    print(f"near q5 = 0: duration {diag['duration']:.3f} s, smallest singular value "
          f"{diag['min_singular_value']:.4f}")  # fmt: skip
    for warning in diag["warnings"]:
        print(f"  warning: {warning}")
    expect(any("slow the tool" in w for w in diag["warnings"]), "expected a slow-down warning")
    # The wrist ends turned by pi on the other side of the singularity (same pose, no flip).
    check_trajectory(NEAR, body, end_on_goal=True)
    print("OK")


if __name__ == "__main__":
    main()
