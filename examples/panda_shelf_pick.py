"""Panda: reach into a shelf, around its boards, with a collision-free motion.

A bookshelf stands in front of the arm (two sides, a back, a lower and a middle board and a top,
2 cm thick); the part waits in the lower compartment, to be grasped with the hand horizontal. The
arm starts at home, its hand above the middle board. The straight joint motion to the grasp
configuration drives the wrist through the middle board (the service says where: 422 `collision`);
`/v1/trajectories/collision_free` plans around it (RRT-Connect, shortened, smoothed, timed at the
optimum) and answers a motion certified 1 cm clear of every board. Checked here, not on the
service's word:

- the hand ends on the grasp pose (the robot's own forward kinematics, 1e-6 m and rad), at rest;
- every returned point is within the joint position, velocity and acceleration limits;
- 1 cm clearance, by coal's distances between the Panda's collision capsules and the boards (the
  boxes built here), at every returned point and at 4 points between consecutive ones.

Run: ``python examples/panda_shelf_pick.py [--url URL]``.
"""

from __future__ import annotations

import itertools
import math

import coal
import numpy as np
import pinocchio as pin
from _common import client, expect, goal_matrix, points

from robots import registry
from robots.geometry import ROBOT_GEOMETRY

URL = "/v1/trajectories/collision_free"
PANDA = registry.get("panda")
HOME = PANDA.home.tolist()
CLEARANCE = 0.01
X0, X1, HALF_WIDTH, THICK, HEIGHT = 0.55, 0.85, 0.40, 0.02, 0.9
BOARDS = {  # name: (centre, full size) [m], axis-aligned in the base frame
    "left_side": ((0.5 * (X0 + X1), -HALF_WIDTH, 0.45), (X1 - X0, THICK, HEIGHT)),
    "right_side": ((0.5 * (X0 + X1), HALF_WIDTH, 0.45), (X1 - X0, THICK, HEIGHT)),
    "back": ((X1, 0.0, 0.45), (THICK, 2 * HALF_WIDTH, HEIGHT)),
    "lower_board": ((0.5 * (X0 + X1), 0.0, 0.25), (X1 - X0, 2 * HALF_WIDTH, THICK)),
    "middle_board": ((0.5 * (X0 + X1), 0.0, 0.55), (X1 - X0, 2 * HALF_WIDTH, THICK)),
    "top": ((0.5 * (X0 + X1), 0.0, HEIGHT), (X1 - X0, 2 * HALF_WIDTH, THICK)),
}
# Grasp: the hand's approach axis (z of panda_link8) along +x, into the lower compartment.
GRASP = {"position": [0.7, 0.1, 0.4], "orientation": [0.0, math.sin(math.pi / 4), 0.0,
                                                      math.cos(math.pi / 4)]}  # fmt: skip
ENVIRONMENT = {
    "obstacles": [
        {"name": name, "shape": {"type": "box", "size": list(size)},
         "pose": {"position": list(centre), "orientation": [0, 0, 0, 1]}}
        for name, (centre, size) in BOARDS.items()
    ],
    "clearance": CLEARANCE,
}  # fmt: skip
REQUEST = {
    "robot": "panda",
    "start": {"positions": HOME},
    "goal": {"pose": GRASP},
    "environment": ENVIRONMENT,
    "sample_period": 0.01,
}
SWEEP = 4
"""Points checked between two consecutive returned points."""


def capsule_shapes() -> list[tuple[int, coal.Capsule, pin.SE3]]:
    """The Panda's collision capsules as coal shapes: (frame id, capsule, pose in the frame)."""
    out = []
    for c in ROBOT_GEOMETRY["panda"].capsules:
        a, b = np.array(c.a), np.array(c.b)
        axis = b - a
        length = float(np.linalg.norm(axis))
        R = np.eye(3)
        if length > 0.0:  # the capsule's z axis along a -> b
            R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), axis / length).matrix()
        out.append(
            (
                PANDA.model.getFrameId(c.link),
                coal.Capsule(c.radius, length),
                pin.SE3(R, 0.5 * (a + b)),
            )
        )
    return out


def smallest_distance(qs: np.ndarray) -> float:
    """Smallest coal distance [m] between a capsule and a board over the configurations ``qs``."""
    model, data = PANDA.model, PANDA.model.createData()
    boards = [
        (coal.Box(*size), coal.Transform3s(np.eye(3), np.array(centre)))
        for centre, size in BOARDS.values()
    ]
    capsules = capsule_shapes()
    request, low = coal.DistanceRequest(), np.inf
    for q in qs:
        pin.framesForwardKinematics(model, data, q)
        for frame, capsule, placement in capsules:
            M = data.oMf[frame] * placement
            at = coal.Transform3s(M.rotation, M.translation)
            for box, where in boards:
                result = coal.DistanceResult()
                low = min(low, coal.distance(capsule, at, box, where, request, result))
    return float(low)


def main() -> None:
    http = client()
    response = http.post(URL, json=REQUEST)
    expect(
        response.status_code == 200, f"expected 200, got {response.status_code}: {response.text}"
    )
    body = response.json()
    diag = body["diagnostics"]
    times, q, v = points(body)
    acc = np.array([p["accelerations"] for p in body["points"]])
    planner = diag["planner"]
    print(f"  planner {planner['name']}: {planner['iterations']} checks, search "
          f"{planner['plan_time_ms']:.0f} ms; path {diag['path_length']:.3f} rad "
          f"({diag['path_length_ratio']:.2f}x the straight joint segment)")  # fmt: skip
    expect(diag["certified"] is True, "the answer is not certified")

    # The straight joint motion to the same grasp configuration hits the shelf.
    direct = http.post(
        "/v1/trajectories/joint",
        json={"robot": "panda", "profile": "quintic", "start": {"positions": HOME},
              "goal": {"positions": q[-1].tolist()}, "environment": ENVIRONMENT},
    )  # fmt: skip
    problem = direct.json()
    print(f"  the straight joint motion instead: {direct.status_code} {problem.get('code')}: "
          f"{problem.get('detail', '')}")  # fmt: skip
    expect(
        direct.status_code == 422 and problem.get("code") == "collision",
        "the straight motion is clear: this scene does not need a planner",
    )

    T_end = PANDA.fk(q[-1])
    T_goal = goal_matrix(REQUEST)
    position = np.linalg.norm(T_end[:3, 3] - T_goal[:3, 3])
    turn = np.linalg.norm(pin.log3(T_goal[:3, :3].T @ T_end[:3, :3]))
    print(f"  grasp pose reached within {position:.1e} m and {turn:.1e} rad")
    expect(position <= 1e-6 and turn <= 1e-6, "the hand does not end on the grasp pose")
    expect(not v[0].any() and not v[-1].any(), "the motion does not start and end at rest")
    lo, hi = PANDA.position_limits[:, 0], PANDA.position_limits[:, 1]
    expect(np.all((q >= lo - 1e-9) & (q <= hi + 1e-9)), "a joint leaves its position limits")
    expect(np.all(np.abs(v) <= PANDA.velocity_limits * (1 + 1e-9)), "a joint exceeds its speed")
    expect(
        np.all(np.abs(acc) <= PANDA.acceleration_limits * (1 + 1e-9)), "a joint over-accelerates"
    )

    t = np.linspace(0.0, 1.0, SWEEP + 2)[:-1, None]
    dense = np.vstack([a + t * (b - a) for a, b in itertools.pairwise(q)] + [q[-1:]])
    low = smallest_distance(dense)
    print(f"  nearest board by coal: {low * 1000:.2f} mm over {len(dense)} configurations "
          f"(asked {CLEARANCE * 1000:.0f} mm; the service's min_clearance "
          f"{diag['min_clearance'] * 1000:.2f} mm counts its own links too, closest "
          f"{' - '.join(diag['closest']['links'])})")  # fmt: skip
    expect(diag["min_clearance"] <= low + 1e-6, "the service's min_clearance flatters the board")
    expect(low >= CLEARANCE - 1e-6, "the arm comes closer to a board than the clearance")
    print(f"panda shelf pick: {len(times)} points over {times[-1]:.3f} s, around the middle board")
    print("OK")


if __name__ == "__main__":
    main()
