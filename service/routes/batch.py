"""POST /v1/batch: up to 256 plan requests of any kind in one body, answered in order.

Each item is answered by its own endpoint in process (``service.batch``): the same validation,
planning and problem+json as a request of its own, with one parsed robot and one collision model
shared by the items that send the same robot and environment, under one time budget for the
batch. One item's failure is its own answer, never the batch's. ``?stream=ndjson`` sends each
item's answer as a JSON line as soon as it is done, then a summary line.
"""

from __future__ import annotations

import weakref
from collections.abc import AsyncIterator
from typing import Any
from urllib.parse import urlencode

import orjson
from fastapi import APIRouter, Request
from starlette.responses import Response, StreamingResponse
from starlette.types import Receive, Scope, Send

from core.errors import InputError
from service.batch.endpoints import body_fields
from service.batch.run import BatchRun
from service.schemas.batch import (
    MAX_ITEMS,
    STREAM_MEDIA_TYPE,
    STREAM_QUERY,
    BatchRequest,
    BatchResponse,
    Stream,
)
from service.schemas.common import (
    LAYOUT_QUERY,
    PROBLEM_RESPONSES,
    TIME_FORMAT_QUERY,
    Layout,
    TimeFormat,
)

router = APIRouter(prefix="/v1", tags=["batch"])

RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {
        "model": BatchResponse,
        "description": "One result per item, in order (with `?stream=ndjson`: one JSON line per "
        'item as it is done, `{index, endpoint, status, body}`, then `{"summary": {...}}`).',
        "content": {STREAM_MEDIA_TYPE: {"schema": {"type": "string"}}},
    },
    **PROBLEM_RESPONSES,
}


class _HeldResponse(Response):
    """The whole answer; the batch's bytes held in the worker's budget are returned once it is
    sent (or, never sent, when it is dropped)."""

    def __init__(self, content: bytes, run: BatchRun) -> None:
        super().__init__(content, media_type="application/json")
        self._run = run
        weakref.finalize(self, run.release)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        try:
            await super().__call__(scope, receive, send)
        finally:
            self._run.release()


def _check_defaults(body: BatchRequest) -> None:
    """A key of ``defaults`` that no item's endpoint takes is a mistake: 422 at that key."""
    taken = frozenset().union(*(body_fields(item.endpoint) for item in body.items))
    for key in body.defaults:
        if key not in taken:
            raise InputError("no item's endpoint takes this field", field=("defaults", key))


@router.post(
    "/batch",
    responses=RESPONSES,
    summary=f"Up to {MAX_ITEMS} plan requests of any kind, answered in order",
    description=(
        "Each item names an endpoint (`trajectories/joint`, `trajectories/cartesian`, `fk`, ...) "
        "and carries that endpoint's request body; it is answered as that endpoint answers the "
        "same body (status and body; a failure's body is the endpoint's problem+json), so one "
        "failure never fails the others. Items run one after another, sharing one parsed robot "
        "and one collision model between those that send the same robot and environment. "
        "`defaults` fills top-level fields of every item that takes them (send an inline URDF "
        "or an environment once). `?time_format=` and `?layout=` apply to every item. Bounded "
        "by `TRAJ_BATCH_BUDGET_S` (an item not started by then is 422 `time_budget_exceeded`) "
        "and by `TRAJ_MAX_RESPONSE_BYTES` for the whole answer (an item past it is 422 "
        "`too_large`). `?stream=ndjson` answers each item as a JSON line as soon as it is done."
    ),
)
async def batch(
    body: BatchRequest,
    request: Request,
    stream: Stream | None = STREAM_QUERY,
    time_format: TimeFormat = TIME_FORMAT_QUERY,
    layout: Layout = LAYOUT_QUERY,
) -> Response:
    _check_defaults(body)
    query = urlencode([(k, v) for k, v in request.query_params.multi_items() if k != "stream"])
    settings = request.app.state.settings
    if stream is not None:
        run = BatchRun(request.scope, body, query.encode(), settings)
        return StreamingResponse(_lines(run), media_type=STREAM_MEDIA_TYPE)
    run = BatchRun(request.scope, body, query.encode(), settings, request.is_disconnected)
    try:
        results = [result.document() async for result in run.results()]
        content = orjson.dumps({"results": results, "summary": run.summary()})
    except BaseException:
        run.release()
        raise
    return _HeldResponse(content, run)


async def _lines(run: BatchRun) -> AsyncIterator[bytes]:
    """One line per item as soon as it is answered (its bytes returned to the worker's budget
    once sent), then the summary line."""
    try:
        async for result in run.results():
            yield orjson.dumps(result.document()) + b"\n"
            run.release()
        yield orjson.dumps({"summary": run.summary()}) + b"\n"
    finally:
        run.release()
