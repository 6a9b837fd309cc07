"""One example request body per operation of ``/openapi.json`` (by ``operation_id``), named
``{name: {"summary", "value"}}`` as OpenAPI 3.1's ``examples`` of a media type: Swagger UI offers
them in a drop-down, ReDoc shows them, and a client generator's user sees a request that works.
They are the requests of docs/api.md and the README; ``tests/service/test_openapi.py`` sends every
one to the app and expects 200.
"""

from __future__ import annotations

from typing import Any

from service.schemas.batch import EXAMPLE as BATCH_EXAMPLE

UR5_HOME = [0, -1.047, 1.571, -2.094, -1.571, 0]
PANDA_READY = [0, -0.785, 0, -2.356, 0, 1.571, 0.785]
DOWN = [0.7071068, 0.7071068, 0, 0]
"""UR5 tool pointing down (quaternion x, y, z, w)."""
UR5_LINE = {
    "robot": "ur5",
    "start": {"positions": UR5_HOME},
    "goal": {"positions": [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]},
    "max_linear_speed": 0.2,
    "max_angular_speed": 0.8,
}
ONE_JOINT_URDF = (
    '<robot name="one"><link name="base_link"/><link name="tool0"/>'
    '<joint name="j1" type="revolute"><parent link="base_link"/><child link="tool0"/>'
    '<origin xyz="0 0 0"/><axis xyz="0 0 1"/>'
    '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
)
BALL = {
    "name": "ball",
    "shape": {"type": "sphere", "radius": 0.05},
    "pose": {"position": [-0.55, -0.1, 0.2], "orientation": [0, 0, 0, 1]},
}


def _example(summary: str, value: dict[str, Any]) -> dict[str, Any]:
    return {"summary": summary, "value": value}


REQUEST_EXAMPLES: dict[str, dict[str, dict[str, Any]]] = {
    "describe_robot": {
        "inline": _example("A one-joint arm sent as URDF", {"robot": {"urdf": ONE_JOINT_URDF}}),
        "named": _example("A registered robot", {"robot": "ur5"}),
    },
    "forward_kinematics": {
        "ur5": _example("UR5 at its home", {"positions": UR5_HOME}),
        "frames": _example("Every link frame too", {"positions": UR5_HOME, "frames": True}),
        "rows": _example(
            "Many configurations in one request: one answer per row",
            {"positions": [UR5_HOME, [0.3, -1.2, 1.8, -2.2, -1.3, 0.4]], "frames": True},
        ),
    },
    "forward_kinematics_inline": {
        "planar": _example(
            "The planar arm, named in the body",
            {"robot": "planar_2r", "positions": [0, 1.5707963267948966]},
        ),
        "rows": _example(
            "Both elbows of the planar arm in one request",
            {"robot": "planar_2r", "positions": [[0, 1.5707963267948966], [0.5, -1.0]]},
        ),
    },
    "inverse_kinematics": {
        "nearest": _example(
            "The UR5 solution nearest a seed",
            {"pose": {"position": [-0.4, -0.11, 0.3], "orientation": DOWN}, "seed": UR5_HOME},
        ),
        "all": _example(
            "Every UR5 solution of a pose, with configuration labels",
            {"pose": {"position": [-0.4, -0.11, 0.3], "orientation": DOWN}, "all": True},
        ),
    },
    "inverse_kinematics_inline": {
        "planar": _example(
            "Both elbow solutions of the planar arm",
            {
                "robot": "planar_2r",
                "pose": {"position": [1.2, 0.5, 0], "orientation": [0, 0, 0, 1]},
                "all": True,
            },
        ),
    },
    "compute_distances": {
        "ball": _example(
            "UR5 links against a ball",
            {"positions": UR5_HOME, "environment": {"obstacles": [BALL]}},
        ),
    },
    "compute_distances_inline": {
        "panda": _example(
            "Self-distances of the Panda", {"robot": "panda", "positions": PANDA_READY}
        ),
    },
    "plan_joint_trajectory": {
        "quintic": _example(
            "Quintic, shortest duration under limits",
            {
                "profile": "quintic",
                "start": {"positions": [0, 0]},
                "goal": {"positions": [1, -0.5]},
                "limits": {"velocity": [1, 1], "acceleration": [2, 2]},
                "samples": 5,
            },
        ),
        "jerk_limited": _example(
            "Jerk-limited (Ruckig) on the Panda",
            {
                "robot": "panda",
                "profile": "jerk_limited",
                "start": {"positions": PANDA_READY},
                "goal": {"positions": [0.5, -0.5, 0.2, -2.0, 0.1, 1.8, 0.9]},
            },
        ),
    },
    "plan_spline_trajectory": {
        "clamped": _example(
            "Knot times from the limits",
            {
                "waypoints": [[0, 0], [1, 0.5], [0.5, 1.5], [2, 1]],
                "boundary": "clamped",
                "limits": {"velocity": [1, 0.8], "acceleration": [2, 3]},
                "samples": 20,
            },
        ),
    },
    "plan_cartesian_trajectory": {
        "line": _example("UR5 straight line, sampled IK", {**UR5_LINE, "method": "sampled"}),
        "arc": _example(
            "UR5 circular arc through an interim point, S-curve speed",
            {
                "robot": "ur5",
                "method": "sampled",
                "start": {"positions": UR5_HOME},
                "goal": {
                    "pose": {
                        "position": [-0.5775, 0.0109, 0.1785],
                        "orientation": [0.7071, 0.7071, 0.0004, 0.0002],
                    }
                },
                "path": {"type": "circ", "interim": [-0.5775, -0.0691, 0.1785]},
                "speed_profile": "s_curve",
                "max_linear_jerk": 2.0,
            },
        ),
    },
    "compare_cartesian_methods": {
        "three": _example(
            "One line, three methods",
            {
                "task": UR5_LINE,
                "methods": ["sampled", "bounded_deviation", "resolved_rate_dls"],
            },
        ),
    },
    "plan_program_trajectory": {
        "weld": _example(
            "PTP to a pose, then LINs with a blend",
            {
                "robot": "ur5",
                "start": {"positions": UR5_HOME},
                "segments": [
                    {
                        "type": "ptp",
                        "goal": {"pose": {"position": [-0.5, -0.1, 0.3], "orientation": DOWN}},
                    },
                    {
                        "type": "lin",
                        "goal": {"pose": {"position": [-0.5, -0.1, 0.2], "orientation": DOWN}},
                        "max_linear_speed": 0.1,
                        "blend_radius": 0.02,
                    },
                    {
                        "type": "lin",
                        "goal": {"pose": {"position": [-0.5, 0.1, 0.2], "orientation": DOWN}},
                        "max_linear_speed": 0.1,
                    },
                ],
            },
        ),
    },
    "retime_trajectory": {
        "via_points": _example(
            "Three UR5 via points, blended corners, time-optimal under the robot's limits",
            {
                "robot": "ur5",
                "waypoints": [
                    UR5_HOME,
                    [0.3, -1.2, 1.8, -2.2, -1.3, 0.4],
                    [0.6, -1.0, 1.5, -2.0, -1.4, 0.8],
                ],
                "path": "blended",
                "max_deviation": 0.05,
            },
        ),
    },
    "plan_batch": {
        "two_items": _example("A joint move and an FK query in one batch", BATCH_EXAMPLE),
    },
    "plan_collision_free_trajectory": {
        "around_a_ball": _example(
            "UR5 around a ball on the direct joint path, 2 cm clearance",
            {
                "robot": "ur5",
                "start": {"positions": UR5_HOME},
                "goal": {"positions": [1.2, -1.3, 1.9, -2.2, -1.4, 0.4]},
                "environment": {
                    "obstacles": [
                        {
                            "name": "ball",
                            "shape": {"type": "sphere", "radius": 0.05},
                            "pose": {
                                "position": [-0.423, -0.43, 0.191],
                                "orientation": [0, 0, 0, 1],
                            },
                        }
                    ],
                    "clearance": 0.02,
                },
            },
        ),
    },
}
