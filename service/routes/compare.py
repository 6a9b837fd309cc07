"""POST /v1/compare: one Cartesian task through every method, diagnostics side by side.

The robot and the task are resolved once (an invalid task fails the whole request); then each method
plans the same task under ONE wall-time budget for the whole request (``TRAJ_TIME_BUDGET_S``): a
method that starts after the budget is spent answers ``time_budget_exceeded`` in its row, so the
request is bounded by the budget, not by the budget times the number of methods. One method's
failure is its row's problem+json, never the request's.
"""

from __future__ import annotations

import time
from typing import Any

from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from core.budget import Deadline
from core.cartesian.methods import METHODS
from core.errors import PlanningError
from robots import registry
from service import deps
from service.convert import cartesian as convert
from service.convert.environment import inline_urdf, unchecked_warnings
from service.convert.robot import with_tool
from service.encoding import json_response
from service.errors import planning_error_body
from service.field_paths import nest
from service.schemas.common import PROBLEM_RESPONSES, TIME_FORMAT_QUERY, TimeFormat
from service.schemas.compare import CompareRequest, CompareResponse

router = APIRouter(prefix="/v1", tags=["compare"])
TASK = ("task",)
"""Where the Cartesian request's fields are in this body."""

RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {"model": CompareResponse, "description": "One row per method"}
}
RESPONSES.update(PROBLEM_RESPONSES)


@router.post(
    "/compare",
    responses=RESPONSES,
    summary="Run one Cartesian task through several methods and compare their diagnostics",
)
def compare(
    body: CompareRequest,
    request: Request,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    deadline: Deadline = Depends(deps.request_deadline),
) -> Response:
    settings = request.app.state.settings
    methods = body.methods or list(METHODS)
    try:
        robot = with_tool(registry.resolve(body.task.robot), body.task.tool)
        task = convert.task_from_spec(
            body.task,
            robot,
            deadline,
            settings.max_points,
            environment_field=("task", "environment"),
        )
    except PlanningError as err:
        nest(err, TASK)  # the task's fields are at task.* of this body
        raise
    unchecked = unchecked_warnings(robot, body.task.environment, inline_urdf(body.task.robot))
    rows = []
    for method in methods:
        started = time.perf_counter()
        try:
            deadline.check(f"compare: before {method}")
            result, elapsed_ms = convert.run(task, method, settings.max_points)
        except PlanningError as err:
            _, problem = planning_error_body(nest(err, TASK), CompareRequest)
            elapsed = (time.perf_counter() - started) * 1e3
            diagnostics = {"method": method, "compute_time_ms": elapsed, "code": err.code}
            rows.append(
                {"method": method, "ok": False, "error": problem, "diagnostics": diagnostics}
            )
            continue
        doc = convert.result_body(result, method, elapsed_ms, time_format, unchecked)
        row: dict[str, Any] = {"method": method, "ok": True, "diagnostics": doc.pop("diagnostics")}
        if body.include_trajectories:
            row["trajectory"] = doc
        rows.append(row)
    return json_response({"results": rows})
