"""Panda: a pick-and-place cycle as one motion program.

PTP to above the part (jerk-limited: the Panda's controller refuses acceleration steps), LIN down
to it (stop: grasp), LIN up, PTP over to above the place position,
LIN down (stop: release). The way up, over and down is blended (5 cm spheres), so the arm does not
stop at the top of either LIN. Checked here with the robot's own forward kinematics:

- the LIN segments, outside the blend windows, are on their vertical lines (1e-6 m) with the hand
  pointing down (1e-6 rad); the grasp and release points are reached exactly and at rest;
- the arm keeps moving through both blends; joint speeds and accelerations stay within limits;
- the same cycle with full stops takes longer (the saving is printed).

Run: ``python examples/panda_pick_place.py [--url URL]``.
"""

from __future__ import annotations

import copy
import math

import numpy as np
from _common import client, expect, points

from core.geometry.so3 import matrix_to_pose
from robots import registry

URL = "/v1/trajectories/program"
HOME = [0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4]
PANDA = registry.get("panda")
T_HOME = PANDA.fk(np.array(HOME))
DOWN = matrix_to_pose(T_HOME)[1].tolist()  # hand pointing down (x, y, z, w), as at home
PICK = np.array([0.5, -0.2, 0.15])
PLACE = np.array([0.45, 0.25, 0.2])
LIFT = np.array([0.0, 0.0, 0.15])
BLEND = 0.05


def pose(p: np.ndarray) -> dict:
    return {"pose": {"position": p.tolist(), "orientation": DOWN}}


REQUEST = {
    "robot": "panda",
    "start": {"positions": HOME},
    "segments": [
        {
            "type": "ptp",
            "goal": pose(PICK + LIFT),
            "velocity_scale": 0.8,
            "profile": "jerk_limited",
        },
        {"type": "lin", "goal": pose(PICK), "max_linear_speed": 0.2},
        {"type": "lin", "goal": pose(PICK + LIFT), "max_linear_speed": 0.3, "blend_radius": BLEND},
        {"type": "ptp", "goal": pose(PLACE + LIFT), "blend_radius": BLEND},
        {"type": "lin", "goal": pose(PLACE), "max_linear_speed": 0.2},
    ],
    "sample_period": 0.005,
}
LINES = {1: (PICK + LIFT, PICK), 2: (PICK, PICK + LIFT), 4: (PLACE + LIFT, PLACE)}


def main() -> None:
    http = client()
    response = http.post(URL, json=REQUEST)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    times, q, v = points(body)
    acc = np.array([p["accelerations"] for p in body["points"]])
    T = PANDA.fk_many(q)
    R_down = T_HOME[:3, :3]
    segs = body["segments"]
    for k, (p0, p1) in LINES.items():
        seg = segs[k]
        sel = (times >= seg["start_time"]) & (times <= seg["end_time"])
        d = (p1 - p0) / np.linalg.norm(p1 - p0)
        rel = T[sel, :3, 3] - p0
        off = np.linalg.norm(rel - np.outer(rel @ d, d), axis=1).max()
        turn = np.abs(T[sel, :3, :3] - R_down).max()
        print(f"  segment {k} (lin): {sel.sum()} points, farthest from its line {off:.2e} m, "
              f"orientation change {turn:.2e}")  # fmt: skip
        expect(off <= 1e-6 and turn <= 1e-6, f"segment {k} leaves its line")
    for k, target in ((1, PICK), (4, PLACE)):
        i = int(np.flatnonzero(times == segs[k]["end_time"])[0])
        expect(np.linalg.norm(T[i, :3, 3] - target) <= 1e-6, f"segment {k} misses its goal")
        expect(np.all(v[i] == 0.0), f"the arm does not stop at the goal of segment {k}")
    # The approach PTP (between stops) is jerk-limited: Ruckig under the Panda's 7500 rad/s^3.
    sel = times <= segs[0]["end_time"]
    jerk = np.abs(np.diff(acc[sel], axis=0) / np.diff(times[sel])[:, None]).max()
    print(f"  segment 0 (ptp, jerk_limited): {segs[0]['end_time']:.3f} s, largest joint jerk "
          f"{jerk:.0f} rad/s^3 (limit {PANDA.jerk_limits.min():.0f})")  # fmt: skip
    expect(jerk <= PANDA.jerk_limits.min() * (1 + 1e-6), "the approach exceeds the jerk limit")
    for k in (2, 3):
        w = segs[k]["blend_out"]
        sel = (times >= w["start_time"]) & (times <= w["end_time"])
        slowest = np.linalg.norm(v[sel], axis=1).min()
        print(f"  blend after segment {k}: {w['end_time'] - w['start_time']:.3f} s, slowest joint "
              f"speed norm {slowest:.3f} rad/s")  # fmt: skip
        expect(slowest > 0.05, f"the arm stops in the blend after segment {k}")
    expect(np.all(np.abs(v) <= PANDA.velocity_limits * (1 + 1e-9)), "a joint exceeds its speed")
    expect(
        np.all(np.abs(acc) <= PANDA.acceleration_limits * (1 + 1e-9)), "a joint over-accelerates"
    )
    stops = copy.deepcopy(REQUEST)
    for seg in stops["segments"]:
        seg.pop("blend_radius", None)
    stopped = http.post(URL, json=stops).json()["diagnostics"]["duration"]
    blended = body["diagnostics"]["duration"]
    print(f"panda pick and place: {len(times)} points; cycle {blended:.3f} s blended against "
          f"{stopped:.3f} s with full stops ({1 - blended / stopped:.1%} saved)")  # fmt: skip
    expect(blended < stopped, "blending does not save time")
    print("OK")


if __name__ == "__main__":
    main()
