"""Plans sent to a running service over HTTP, answers checked: deploy/build_and_run.sh calls it.

``python3 deploy/smoke_check.py http://127.0.0.1:8000`` (standard library only, so it runs with any
Python 3.10+, outside the image). Public API only (shared/API.md). Three plans:

- joint: a quintic move of 3 joints in 2 s, 201 samples. Every sample is checked against the closed
  form q0 + (q1 - q0)(10 tau^3 - 15 tau^4 + 6 tau^5), tau = t / T, with its first and second
  derivatives (1e-9), and the times against k T / 200.
- cartesian, ``sampled``, and ``bounded_deviation_nlp`` (CasADi + IPOPT inside the image): the UR5
  from its home to joint goal ``home + delta``. The answer starts at the start and ends at the goal
  (1e-6 rad), at rest, with strictly increasing times, the whole line (``fraction`` 1) and the
  measured deviation within the tolerance.

Exit status 0 when every check holds; otherwise each failed check is printed and the status is 1.
"""

from __future__ import annotations

import itertools
import json
import math
import sys
import time
import urllib.error
import urllib.request
from typing import Any

UR5_HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
UR5_DELTA = [0.25, -0.15, 0.2, 0.1, 0.15, -0.2]
TOLERANCE = {"position": 1e-3, "orientation": 1e-2}
failures: list[str] = []


def check(condition: bool, message: str) -> None:
    if not condition:
        failures.append(message)
        print(f"FAILED: {message}")


def post(base: str, path: str, body: dict[str, Any]) -> tuple[int, dict[str, Any], float]:
    """Status, JSON body and wall time [s] of one POST."""
    request = urllib.request.Request(
        base + path,
        data=json.dumps(body).encode(),
        headers={"Content-Type": "application/json", "Accept": "application/json"},
        method="POST",
    )
    start = time.perf_counter()
    try:
        with urllib.request.urlopen(request, timeout=60) as response:
            status, raw = response.status, response.read()
    except urllib.error.HTTPError as error:
        status, raw = error.code, error.read()
    return status, json.loads(raw), time.perf_counter() - start


def quintic(q0: float, q1: float, T: float, t: float) -> tuple[float, float, float]:
    """Rest-to-rest quintic: position, velocity, acceleration at t."""
    tau, d = t / T, q1 - q0
    return (
        q0 + d * (10 * tau**3 - 15 * tau**4 + 6 * tau**5),
        d * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / T,
        d * (60 * tau - 180 * tau**2 + 120 * tau**3) / T**2,
    )


def joint_plan(base: str) -> None:
    start, goal, duration, samples = [0.0, 0.5, -1.0], [1.0, -0.5, 0.25], 2.0, 201
    status, body, wall = post(
        base,
        "/v1/trajectories/joint",
        {
            "profile": "quintic",
            "start": {"positions": start},
            "goal": {"positions": goal},
            "duration": duration,
            "samples": samples,
        },
    )
    print(f"joint quintic: {status} in {wall * 1000:.0f} ms")
    check(status == 200, f"joint: status {status}: {body}")
    if status != 200:
        return
    points = body["points"]
    check(len(points) == samples, f"joint: {len(points)} points, not {samples}")
    worst = 0.0
    for k, point in enumerate(points):
        t = point["time_from_start"]
        worst = max(worst, abs(t - k * duration / (samples - 1)))
        for j in range(3):
            expected = quintic(start[j], goal[j], duration, t)
            got = (point["positions"][j], point["velocities"][j], point["accelerations"][j])
            worst = max(worst, *(abs(a - b) for a, b in zip(got, expected, strict=True)))
    check(worst <= 1e-9, f"joint: off the closed-form quintic by {worst:.3g}")
    check(body["joint_names"] == ["j1", "j2", "j3"], f"joint: names {body['joint_names']}")
    check(abs(body["diagnostics"]["duration"] - duration) <= 1e-12, "joint: diagnostics.duration")


def cartesian_plan(base: str, method: str) -> None:
    goal = [h + d for h, d in zip(UR5_HOME, UR5_DELTA, strict=True)]
    status, body, wall = post(
        base,
        "/v1/trajectories/cartesian",
        {
            "robot": "ur5",
            "start": {"positions": UR5_HOME},
            "goal": {"positions": goal},
            "method": method,
            "tolerance": TOLERANCE,
        },
    )
    diagnostics = body.get("diagnostics", {})
    print(
        f"cartesian {method} on the UR5: {status} in {wall * 1000:.0f} ms, "
        f"{len(body.get('points', []))} points, knots {diagnostics.get('knot_count')}"
    )
    check(status == 200, f"{method}: status {status}: {body}")
    if status != 200:
        return
    points = body["points"]
    times = [p["time_from_start"] for p in points]
    check(times[0] == 0.0, f"{method}: first time {times[0]}")
    check(all(b > a for a, b in itertools.pairwise(times)), f"{method}: times not increasing")
    first, last = points[0], points[-1]
    check(
        max(abs(a - b) for a, b in zip(first["positions"], UR5_HOME, strict=True)) <= 1e-6,
        f"{method}: first point {first['positions']} is not the start",
    )
    check(
        max(abs(a - b) for a, b in zip(last["positions"], goal, strict=True)) <= 1e-6,
        f"{method}: last point {last['positions']} is not the goal {goal}",
    )
    check(max(map(abs, last["velocities"])) <= 1e-9, f"{method}: not at rest at the end")
    check(diagnostics["method"] == method, f"{method}: diagnostics.method {diagnostics['method']}")
    check(diagnostics["fraction"] == 1.0, f"{method}: fraction {diagnostics['fraction']}")
    check(
        diagnostics["max_position_deviation"] <= TOLERANCE["position"] * (1 + 1e-9),
        f"{method}: position deviation {diagnostics['max_position_deviation']}",
    )
    check(
        diagnostics["max_orientation_deviation"] <= TOLERANCE["orientation"] * (1 + 1e-9),
        f"{method}: orientation deviation {diagnostics['max_orientation_deviation']}",
    )
    numbers = [v for p in points for key in ("positions", "velocities") for v in p[key]]
    check(all(math.isfinite(v) for v in numbers), f"{method}: a number is not finite")


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python3 smoke_check.py BASE_URL", file=sys.stderr)
        return 2
    base = argv[1].rstrip("/")
    joint_plan(base)
    cartesian_plan(base, "sampled")
    cartesian_plan(base, "bounded_deviation_nlp")
    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    print("smoke check: every plan checked")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
