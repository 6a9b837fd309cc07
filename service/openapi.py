"""``/openapi.json`` ready for client generators: stable operation ids, an example for every request
body, the description of what the service does today.

- ``operation_id``: ``OPERATION_IDS`` by (method, path), snake_case verbs a generated client turns
  into method names (``plan_joint_trajectory``); a route not listed gets its function's name
  (FastAPI's default, ``plan_joint_v1_trajectories_joint_post``, changes with the path and reads
  badly). ``create_app`` passes ``operation_id`` as ``generate_unique_id_function``.
- Request examples: ``service.openapi_examples.REQUEST_EXAMPLES``, added to each request body's
  ``application/json`` media type as OpenAPI 3.1 ``examples`` when the schema is first built.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.routing import APIRoute

from service.openapi_examples import REQUEST_EXAMPLES

DESCRIPTION = """\
Plans robot trajectories over HTTP. POST a plan request (a robot, a start, a goal, limits, a method)
and get a timed trajectory in the shape of ROS `trajectory_msgs/JointTrajectory`, with diagnostics.

- Joint space: `linear`, `cubic`, `quintic`, `trapezoidal` and `jerk_limited` (Ruckig)
  point-to-point moves; C2 cubic splines through waypoints.
- Robots: `planar_2r`, `puma560`, `ur5`, `panda`, or any robot sent as URDF; forward kinematics,
  inverse kinematics with every solution and its configuration label.
- Cartesian lines and circular arcs: sampled IK, Taylor's bounded deviation, its NLP form
  (CasADi + IPOPT), resolved-rate control (pseudo-inverse, damped least-squares QP); trapezoidal
  or S-curve speed profiles; `POST /v1/compare` runs several methods on one task.
- Motion programs: PTP, LIN and CIRC segments with blends, as one trajectory.
- Collisions: obstacles and self-collision, checked continuously along every answer.

SI units everywhere (m, rad, s). Every failure is `application/problem+json` with a machine-readable
`code` and, along a path, the path parameter `s`. The full contract, with a worked example per
endpoint, is `docs/api.md` in the project's repository.
"""

OPERATION_IDS: dict[tuple[str, str], str] = {
    ("GET", "/health"): "get_health",
    ("GET", "/ready"): "get_readiness",
    ("GET", "/v1/robots"): "list_robots",
    ("GET", "/v1/robots/{name}"): "get_robot",
    ("POST", "/v1/robots/describe"): "describe_robot",
    ("POST", "/v1/robots/{name}/fk"): "forward_kinematics",
    ("POST", "/v1/fk"): "forward_kinematics_inline",
    ("POST", "/v1/robots/{name}/ik"): "inverse_kinematics",
    ("POST", "/v1/ik"): "inverse_kinematics_inline",
    ("POST", "/v1/robots/{name}/distance"): "compute_distances",
    ("POST", "/v1/distance"): "compute_distances_inline",
    ("POST", "/v1/trajectories/joint"): "plan_joint_trajectory",
    ("POST", "/v1/trajectories/spline"): "plan_spline_trajectory",
    ("POST", "/v1/trajectories/cartesian"): "plan_cartesian_trajectory",
    ("POST", "/v1/trajectories/program"): "plan_program_trajectory",
    ("POST", "/v1/trajectories/retime"): "retime_trajectory",
    ("POST", "/v1/trajectories/collision_free"): "plan_collision_free_trajectory",
    ("POST", "/v1/compare"): "compare_cartesian_methods",
    ("POST", "/v1/batch"): "plan_batch",
}


def operation_id(route: APIRoute) -> str:
    """The route's ``operation_id``: from ``OPERATION_IDS``, else the endpoint function's name."""
    for method in sorted(route.methods or ()):
        known = OPERATION_IDS.get((method, route.path_format))
        if known:
            return known
    return route.name


def install(app: FastAPI) -> None:
    """Wrap ``app.openapi`` (FastAPI's, as ``service.errors`` left it) so that the schema carries
    ``REQUEST_EXAMPLES`` on the request bodies."""
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        schema = generate()
        add_examples(schema)  # idempotent: the schema is built once and cached by FastAPI
        return schema

    app.openapi = openapi  # type: ignore[method-assign]


def add_examples(schema: dict[str, Any]) -> None:
    """``REQUEST_EXAMPLES[operation_id]`` as the ``examples`` of each JSON request body."""
    for operations in schema.get("paths", {}).values():
        for operation in operations.values():
            media = operation.get("requestBody", {}).get("content", {}).get("application/json")
            examples = REQUEST_EXAMPLES.get(operation.get("operationId", ""))
            if media is not None and examples:
                media["examples"] = examples
