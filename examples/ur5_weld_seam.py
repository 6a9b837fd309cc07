"""UR5: a rectangular weld seam with rounded corners, as one motion program.

The torch (tool z pointing down) starts in the middle of the seam's first side and goes around the
20 x 12 cm rectangle back to where it started: five LIN segments (the first side is split where
the torch starts) and four blends of 3 cm, one at each corner, so the torch never stops. Checked
here with the robot's own forward kinematics and this script's own geometry:

- outside the blend windows every returned point is on its side of the rectangle (1e-6 m) with
  the torch orientation unchanged (1e-6 rad);
- in each blend window the torch stays within 3 cm of the corner and keeps moving;
- joint speeds and accelerations stay within the limits; the program ends at rest on its start;
- the same seam with full stops at the corners takes longer (the saving is printed).

Run: ``python examples/ur5_weld_seam.py [--url URL]``.
"""

from __future__ import annotations

import copy
import math

import numpy as np
from _common import client, expect, points

from robots import registry

URL = "/v1/trajectories/program"
HOME = [0.0, -math.pi / 3, math.pi / 2, -2 * math.pi / 3, -math.pi / 2, 0.0]
UR5 = registry.get("ur5")
T_HOME = UR5.fk(np.array(HOME))
DOWN = [0.7071067811865476, 0.7071067811865475, 0.0, 0.0]  # the home torch orientation (x, y, z, w)
RADIUS = 0.03
START = T_HOME[:3, 3]
# Corners of the rectangle (20 cm along x, 12 cm along y); the torch starts mid-way along A-B.
X, Y = np.array([0.1, 0.0, 0.0]), np.array([0.0, 0.12, 0.0])
A, B = START - X, START + X
C, D = B + Y, A + Y
PATH = [START, B, C, D, A, START]


def lin(p: np.ndarray, blend: float) -> dict:
    return {
        "type": "lin",
        "goal": {"pose": {"position": p.tolist(), "orientation": DOWN}},
        "max_linear_speed": 0.1,
        "blend_radius": blend,
    }


REQUEST = {
    "robot": "ur5",
    "start": {"positions": HOME},
    "segments": [lin(p, RADIUS if k < 4 else 0.0) for k, p in enumerate(PATH[1:])],
    "sample_period": 0.004,
}


def main() -> None:
    http = client()
    response = http.post(URL, json=REQUEST)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    times, q, v = points(body)
    acc = np.array([p["accelerations"] for p in body["points"]])
    T = UR5.fk_many(q)
    segs = body["segments"]
    worst_line, worst_turn = 0.0, 0.0
    for seg, p0, p1 in zip(segs, PATH[:-1], PATH[1:], strict=True):
        sel = (times >= seg["start_time"]) & (times <= seg["end_time"])
        d = (p1 - p0) / np.linalg.norm(p1 - p0)
        rel = T[sel, :3, 3] - p0
        off = np.linalg.norm(rel - np.outer(rel @ d, d), axis=1)
        worst_line = max(worst_line, float(off.max()))
        worst_turn = max(worst_turn, float(np.abs(T[sel, :3, :3] - T_HOME[:3, :3]).max()))
        if "blend_out" in seg:
            w = seg["blend_out"]
            sel = (times >= w["start_time"]) & (times <= w["end_time"])
            dist = np.linalg.norm(T[sel, :3, 3] - p1, axis=1)
            speed = np.linalg.norm(np.diff(T[sel, :3, 3], axis=0), axis=1) / np.diff(times[sel])
            print(f"  corner {seg['index'] + 1}: closest {dist.min() * 100:.2f} cm, slowest "
                  f"{speed.min():.3f} m/s over {w['end_time'] - w['start_time']:.3f} s")  # fmt: skip
            expect(dist.max() <= RADIUS + 1e-6, "the torch leaves a blend sphere inside a blend")
            expect(speed.min() > 0.01, "the torch stops at a blended corner")
    print(f"ur5 weld seam: {len(times)} points over {times[-1]:.3f} s; farthest from the seam "
          f"{worst_line:.2e} m, orientation change {worst_turn:.2e}")  # fmt: skip
    expect(worst_line <= 1e-6, "a point outside the blends is off the seam")
    expect(worst_turn <= 1e-6, "the torch turns")
    expect(np.all(np.abs(v) <= UR5.velocity_limits * (1 + 1e-9)), "a joint exceeds its speed limit")
    expect(np.all(np.abs(acc) <= UR5.acceleration_limits * (1 + 1e-9)), "a joint over-accelerates")
    expect(np.all(v[-1] == 0.0), "the program does not end at rest")
    expect(np.linalg.norm(T[-1, :3, 3] - START) <= 1e-6, "the seam does not close")
    stops = copy.deepcopy(REQUEST)
    for seg in stops["segments"]:
        seg["blend_radius"] = 0.0
    stopped = http.post(URL, json=stops).json()["diagnostics"]["duration"]
    blended = body["diagnostics"]["duration"]
    print(f"  cycle time {blended:.3f} s blended against {stopped:.3f} s with full stops "
          f"({1 - blended / stopped:.1%} saved)")  # fmt: skip
    expect(blended < stopped, "blending does not save time")
    print("OK")


if __name__ == "__main__":
    main()
