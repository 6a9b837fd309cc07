"""One batch, run: its items answered one after another, in order, under its budget and limits.

- **Sharing.** One ``service.memo.Memo`` for the whole batch: every item runs in a context that
  holds it, so items sending the same robot and environment share one parsed robot and one
  collision model (``Memo.stats`` counts what was built and reused).
- **Time.** ``TRAJ_BATCH_BUDGET_S`` from the start: an item not started by then is answered 422
  ``time_budget_exceeded`` without running (as ``/v1/compare`` answers a method it did not start),
  and a running item's own deadline ends no later than the batch's (``deps.BATCH_DEADLINE``).
- **Size and memory.** Each item's answer passes its endpoint's own admission (the per-answer cap,
  the worker's budget of answer bytes in flight). The batch then holds the item's bytes in that
  budget until they are sent (503 ``overloaded`` for the item when others hold it), and the
  bytes of all items together stay within ``TRAJ_MAX_RESPONSE_BYTES``: an item that would take
  the answer past it is 422 ``too_large`` in its place (later, smaller items still run).
"""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass
from typing import Any

import orjson
from starlette.types import Scope

from core.budget import Deadline
from core.errors import TimeBudgetExceeded, TooLarge
from service import deps, memo
from service.batch.endpoints import ENDPOINTS, body_fields
from service.batch.subrequest import Answer, internal_error, post
from service.encoding import RESPONSE_BUDGET, Reservation
from service.errors import Overloaded, planning_error_body
from service.problem import problem_bytes
from service.schemas.batch import BatchItem, BatchRequest
from service.settings import Settings


@dataclass(frozen=True)
class ItemResult:
    """An item's answer: its ``index`` in the batch, ``endpoint``, ``status`` and ``body`` (JSON)."""

    index: int
    endpoint: str
    status: int
    body: bytes

    def document(self) -> dict[str, Any]:
        """The item's entry in the answer (its body embedded as the bytes it already is)."""
        return {
            "index": self.index,
            "endpoint": self.endpoint,
            "status": self.status,
            "body": orjson.Fragment(self.body),
        }


def item_body(body: dict[str, Any], defaults: dict[str, bytes], fields: frozenset[str]) -> bytes:
    """The JSON an item's endpoint receives: the item's body plus each default (pre-encoded) it
    takes and does not set. ``json.dumps`` writes what ``json.loads`` read, NaN and Infinity
    included, so the endpoint rejects them at their field as it would in a request of its own."""
    own = json.dumps(body, separators=(",", ":")).encode()
    added = [
        json.dumps(k).encode() + b":" + v
        for k, v in defaults.items()
        if k in fields and k not in body
    ]
    if not added:
        return own
    return b"{" + b",".join([*added, *([own[1:-1]] if len(own) > 2 else [])]) + b"}"


class BatchRun:
    """A batch's items answered in order (``results()``), with what it shares and holds.

    Args:
        scope: The batch request's ASGI scope (each item is a request to the same app).
        batch: The validated envelope.
        query: The query string every item gets (the batch's ``time_format`` and ``layout``).
        settings: The app's settings (budget, size limits).
        disconnected: Awaitable check of the client having gone; no item starts after it has.
    """

    def __init__(
        self,
        scope: Scope,
        batch: BatchRequest,
        query: bytes,
        settings: Settings,
        disconnected: Callable[[], Awaitable[bool]] | None = None,
    ) -> None:
        self.scope, self.batch, self.query, self.settings = scope, batch, query, settings
        self.disconnected = disconnected
        self.memo = memo.Memo()
        self.deadline = Deadline(settings.batch_budget_s)
        self.started = time.perf_counter()
        self.defaults = {k: json.dumps(v).encode() for k, v in batch.defaults.items()}
        self.held: list[Reservation] = []
        self.answer_bytes = 0
        self.succeeded = self.failed = self.not_started = 0

    async def results(self) -> AsyncIterator[ItemResult]:
        """Each item's result as soon as it is known, in order."""
        for index, item in enumerate(self.batch.items):
            if self.deadline.expired():
                result = self._not_started(index, item)
            elif self.disconnected is not None and await self.disconnected():
                return
            else:
                result = self._admit(index, item, await self._answer(item))
            if 200 <= result.status < 300:
                self.succeeded += 1
            else:
                self.failed += 1
            yield result

    async def _answer(self, item: BatchItem) -> Answer:
        """The item's answer from its endpoint, in a task whose context holds the batch's memo
        and deadline (the item's own context changes stay in it)."""
        body = item_body(item.body, self.defaults, body_fields(item.endpoint))
        memo_token = memo.MEMO.set(self.memo)
        deadline_token = deps.BATCH_DEADLINE.set(self.deadline)
        try:
            task = asyncio.create_task(
                post(self.scope, ENDPOINTS[item.endpoint].path, body, self.query)
            )
        finally:
            deps.BATCH_DEADLINE.reset(deadline_token)
            memo.MEMO.reset(memo_token)
        return await task

    def _not_started(self, index: int, item: BatchItem) -> ItemResult:
        self.not_started += 1
        budget = self.settings.batch_budget_s
        err = TimeBudgetExceeded(
            f"the batch's wall-time budget of {budget:g} s was spent before this item started",
            extra={"budget_s": budget},
        )
        status, body = planning_error_body(err)
        return ItemResult(index, item.endpoint, status, orjson.dumps(body))

    def _admit(self, index: int, item: BatchItem, answer: Answer) -> ItemResult:
        """The item's result once its bytes are admitted into the batch's answer (or the failure
        that takes its place: too large for what is left, or the worker's budget in use)."""
        if "json" not in answer.media_type:  # every endpoint answers JSON: a defect otherwise
            answer = internal_error()
        size, limit = len(answer.body), self.settings.max_response_bytes
        if self.answer_bytes + size > limit:
            status, body = planning_error_body(
                TooLarge(
                    f"the batch's answer would take {self.answer_bytes + size} bytes with this "
                    f"item; at most {limit} are allowed: send it in another batch",
                    extra={"estimated_bytes": self.answer_bytes + size, "limit_bytes": limit},
                )
            )
            return ItemResult(index, item.endpoint, status, orjson.dumps(body))
        try:
            self.held.append(RESPONSE_BUDGET.reserve(size, self.settings.response_budget_bytes))
        except Overloaded as exc:
            body_bytes = problem_bytes(
                503, "overloaded", "Service overloaded", str(exc), retry_after_s=exc.retry_after_s
            )
            return ItemResult(index, item.endpoint, 503, body_bytes)
        self.answer_bytes += size
        return ItemResult(index, item.endpoint, answer.status, answer.body)

    def release(self) -> None:
        """Return the bytes held for answers already sent to the worker's budget (idempotent)."""
        held, self.held = self.held, []
        for reservation in held:
            reservation.release()

    def summary(self) -> dict[str, Any]:
        """Counts, wall time [ms], the budget [s] and what the memo shared."""
        return {
            "items": len(self.batch.items),
            "succeeded": self.succeeded,
            "failed": self.failed,
            "not_started": self.not_started,
            "compute_time_ms": (time.perf_counter() - self.started) * 1e3,
            "budget_s": self.settings.batch_budget_s,
            "shared": self.memo.stats(),
        }
