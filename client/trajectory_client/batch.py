"""``POST /v1/batch?stream=ndjson`` from the client: results yielded as the service finishes them.

The service answers one JSON line per item, in order, then a summary line. ``BatchStream`` reads
them as they come and turns each into a ``BatchResult`` (the typed value, or the exception the
endpoint's own method would raise). A connection dropped mid-stream is not the end: the items not
answered yet are sent again as a new batch (after the retry policy's wait), so every item is
answered once; 503 ``overloaded`` before the stream starts is retried like any request.
"""

from __future__ import annotations

import json
from collections.abc import Generator, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import httpx

from trajectory_client.endpoints import parse
from trajectory_client.errors import TransportError, error_for
from trajectory_client.results import BatchResult
from trajectory_client.retry import RETRYABLE_TRANSPORT

if TYPE_CHECKING:
    from trajectory_client.client import TrajectoryClient

STREAM_PARAMS = {"stream": "ndjson", "layout": "columns"}


@dataclass(frozen=True)
class BatchItem:
    """One request of a batch: ``endpoint`` (its path after ``/v1/``) and its JSON ``body``."""

    endpoint: str
    body: Mapping[str, Any] = field(default_factory=dict)


class BatchStream(Iterator[BatchResult]):
    """The results of one batch, in order, as they arrive (iterate it once; ``close()`` or a
    ``with`` block ends it early). ``summary`` is the service's summary line once read (of the
    last resubmission when a connection dropped)."""

    def __init__(
        self,
        client: TrajectoryClient,
        items: list[BatchItem],
        defaults: dict[str, Any],
        as_numpy: bool,
    ) -> None:
        self.client, self.items, self.defaults, self.as_numpy = client, items, defaults, as_numpy
        self.summary: dict[str, Any] | None = None
        self._results = self._run()

    def __next__(self) -> BatchResult:
        return next(self._results)

    def __iter__(self) -> BatchStream:
        return self

    def close(self) -> None:
        self._results.close()

    def __enter__(self) -> BatchStream:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _run(self) -> Generator[BatchResult, None, None]:
        pending = list(range(len(self.items)))
        retry = 0
        while pending:
            sent = list(pending)
            body: dict[str, Any] = {
                "items": [
                    {"endpoint": self.items[i].endpoint, "body": self.items[i].body} for i in sent
                ]
            }
            if self.defaults:
                body["defaults"] = self.defaults
            response = self.client.send("POST", "/v1/batch", body, STREAM_PARAMS, stream=True)
            try:
                for line in response.iter_lines():
                    if not line.strip():
                        continue
                    doc = json.loads(line)
                    if "summary" in doc:
                        self.summary = doc["summary"]
                        continue
                    index = sent[int(doc["index"])]
                    pending.remove(index)
                    yield self._result(index, doc)
            except RETRYABLE_TRANSPORT as exc:
                cause: Exception = exc
            except httpx.TransportError as exc:  # a timeout between two items
                raise TransportError(f"POST /v1/batch: {exc!r}") from exc
            else:
                if not pending:
                    return
                cause = TransportError("the batch's answer ended before its last item")
            finally:
                response.close()
            wait = self.client.retry.delay(retry, None, self.client._rng)
            if wait is None:
                raise TransportError(f"POST /v1/batch: {cause}") from cause
            self.client._sleep(wait)
            retry += 1

    def _result(self, index: int, doc: dict[str, Any]) -> BatchResult:
        endpoint, status, body = str(doc["endpoint"]), int(doc["status"]), doc["body"]
        if 200 <= status < 300:
            value = parse(endpoint, body, self.as_numpy)
            return BatchResult(index, endpoint, status, value, None, body)
        error = error_for(
            status, body, body.get("retry_after_s") if isinstance(body, dict) else None
        )
        return BatchResult(index, endpoint, status, None, error, body)
