"""``TrajectoryClient``: one method per endpoint of the Trajectory Service, synchronous, on httpx.

Request bodies are the service's JSON bodies, given as keyword arguments (or a mapping first, the
keywords added to it): every field the API documents is accepted as it is documented, numpy arrays
and ``Pose`` objects included anywhere. Answers come back typed (``results``); failures raise the
exceptions of ``errors``; 503 ``overloaded`` and dropped connections are retried (``retry``).

A new endpoint is one line of ``endpoints.PARSERS`` (how its answer is read; batches use it too)
and one method calling ``self._call``.
"""

from __future__ import annotations

import json
import random
import time
from collections.abc import Callable, Iterable, Mapping
from typing import Any
from urllib.parse import quote

import httpx

from trajectory_client import __version__
from trajectory_client.batch import BatchItem, BatchStream
from trajectory_client.endpoints import parse
from trajectory_client.errors import Overloaded, TransportError, error_for
from trajectory_client.results import (
    Comparison,
    Distance,
    FKResult,
    Health,
    IKResult,
    Ready,
    Robot,
    Trajectory,
)
from trajectory_client.retry import RETRYABLE_TRANSPORT, RetryPolicy, retry_after_seconds

DEFAULT_URL = "http://127.0.0.1:8000"
"""Where ``python -m service`` listens by default."""
COLUMNS = {"layout": "columns"}
"""Trajectories are asked for as columns: the smallest answer, read straight into arrays."""


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return dict(value)
    if hasattr(value, "to_json"):  # Pose
        return value.to_json()
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def encode(body: Any) -> bytes:
    """JSON bytes of a request body; NaN and infinities raise ``ValueError`` here (the service
    would refuse them)."""
    return json.dumps(body, default=_jsonable, allow_nan=False, separators=(",", ":")).encode()


def _merge(body: Mapping[str, Any] | None, fields: Mapping[str, Any]) -> dict[str, Any]:
    return {**(body or {}), **fields}


def _decoded(response: httpx.Response) -> Any:
    try:
        return response.json()
    except ValueError:
        return response.text


class TrajectoryClient:
    """A client of one service.

    Args:
        base_url: The service's address (``DEFAULT_URL``: ``python -m service`` on this machine).
        timeout: Seconds for each of connect, read, write and pool (or an ``httpx.Timeout``); a
            plan takes at most the service's ``TRAJ_TIME_BUDGET_S`` (10 s by default).
        retry: When and how long to retry (``RetryPolicy()``: 4 tries, 0.2 s doubling, jittered).
        headers: Extra headers on every request (``X-Request-ID``, an API gateway's key ...).
        transport: An ``httpx`` transport (tests, proxies, an ASGI app in process).
        seed: Seed of the retry jitter (None: random).

    Use it as a context manager, or call ``close()``, to close its connections.
    """

    def __init__(
        self,
        base_url: str = DEFAULT_URL,
        *,
        timeout: float | httpx.Timeout = 60.0,
        retry: RetryPolicy | None = None,
        headers: Mapping[str, str] | None = None,
        transport: httpx.BaseTransport | None = None,
        seed: int | None = None,
    ) -> None:
        self.retry = retry or RetryPolicy()
        self._rng = random.Random(seed)
        self._sleep: Callable[[float], None] = time.sleep
        self._http = httpx.Client(
            base_url=base_url.rstrip("/"),
            timeout=timeout,
            headers={"user-agent": f"trajectory-client/{__version__}", **(headers or {})},
            transport=transport,
        )

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> TrajectoryClient:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # --- the wire ---------------------------------------------------------------------------

    def request(
        self,
        method: str,
        path: str,
        body: Any = None,
        params: Mapping[str, str] | None = None,
    ) -> Any:
        """Any endpoint, raw: ``method path`` with the JSON ``body``; the decoded JSON answer, or
        the exception of its problem+json. Retries as the typed methods do."""
        response = self.send(method, path, body, params)
        return response.json()

    def send(
        self,
        method: str,
        path: str,
        body: Any = None,
        params: Mapping[str, str] | None = None,
        *,
        stream: bool = False,
    ) -> httpx.Response:
        """The successful ``httpx.Response`` (with ``stream``, unread: close it), after retrying
        503 ``overloaded`` and failed connections as ``retry`` says; else raise."""
        content = None if body is None else encode(body)
        headers = {} if content is None else {"content-type": "application/json"}
        request = self._http.build_request(
            method, path, content=content, params=params, headers=headers
        )
        retry = 0
        while True:
            try:
                response = self._http.send(request, stream=stream)
            except RETRYABLE_TRANSPORT as exc:
                wait = self.retry.delay(retry, None, self._rng)
                if wait is None:
                    raise TransportError(f"{method} {path}: {exc}") from exc
            except httpx.TransportError as exc:  # a timeout: the service is busy with it
                raise TransportError(f"{method} {path}: {exc!r}") from exc
            else:
                if response.is_success:
                    return response
                response.read()
                response.close()
                after = retry_after_seconds(response.headers.get("retry-after"))
                error = error_for(response.status_code, _decoded(response), after)
                overloaded = isinstance(error, Overloaded)
                wait = self.retry.delay(retry, after, self._rng) if overloaded else None
                if wait is None:
                    raise error
            self._sleep(wait)
            retry += 1

    def _call(
        self,
        endpoint: str,
        body: Mapping[str, Any] | None,
        fields: Mapping[str, Any],
        as_numpy: bool = False,
        params: Mapping[str, str] | None = None,
    ) -> Any:
        doc = self.request("POST", f"/v1/{endpoint}", _merge(body, fields), params)
        return parse(endpoint, doc, as_numpy)

    # --- operations -------------------------------------------------------------------------

    def health(self) -> Health:
        """``GET /health``: the process answers."""
        doc = self.request("GET", "/health")
        return Health(doc["status"], doc["version"])

    def ready(self) -> Ready:
        """``GET /ready``: every robot loaded (``NotReady`` while it starts)."""
        doc = self.request("GET", "/ready")
        return Ready(doc["status"], list(doc["robots"]))

    # --- robots and kinematics -------------------------------------------------------------

    def robots(self) -> list[Robot]:
        """``GET /v1/robots``: the registered robots."""
        return [Robot.from_json(r) for r in self.request("GET", "/v1/robots")]

    def robot(self, name: str) -> Robot:
        """``GET /v1/robots/{name}``: one registered robot with its limits and home."""
        return Robot.from_json(self.request("GET", f"/v1/robots/{quote(name, safe='')}"))

    def describe(self, robot: str | Mapping[str, Any]) -> Robot:
        """``POST /v1/robots/describe``: any robot (a name or an inline URDF model)."""
        return Robot.from_json(self.request("POST", "/v1/robots/describe", {"robot": robot}))

    def fk(self, robot: str | Mapping[str, Any], positions: Any, **fields: Any) -> FKResult:
        """``POST /v1/fk``: pose and Jacobian at ``positions`` (``frame``, ``frames`` ...)."""
        return self._call("fk", {"robot": robot, "positions": positions}, fields)

    def ik(self, robot: str | Mapping[str, Any], pose: Any, **fields: Any) -> IKResult:
        """``POST /v1/ik``: joint positions reaching ``pose`` (``seed``, ``all``,
        ``configuration``, ``fixed_joints``, ``turns``)."""
        return self._call("ik", {"robot": robot, "pose": pose}, fields)

    def distance(self, robot: str | Mapping[str, Any], positions: Any, **fields: Any) -> Distance:
        """``POST /v1/distance``: clearances at ``positions`` (``environment``)."""
        return self._call("distance", {"robot": robot, "positions": positions}, fields)

    # --- trajectories ------------------------------------------------------------------------

    def joint(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Trajectory:
        """``POST /v1/trajectories/joint``: a point-to-point move (``profile``, ``start``,
        ``goal``, ``duration``, ``limits``, ``robot``, ``environment`` ...)."""
        return self._call("trajectories/joint", body, fields, as_numpy, COLUMNS)

    def spline(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Trajectory:
        """``POST /v1/trajectories/spline``: a C2 spline through ``waypoints``."""
        return self._call("trajectories/spline", body, fields, as_numpy, COLUMNS)

    def cartesian(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Trajectory:
        """``POST /v1/trajectories/cartesian``: the tool on a line or arc (``robot``, ``start``,
        ``goal``, ``method`` ...); ``raw["knots"]`` for bounded deviation."""
        return self._call("trajectories/cartesian", body, fields, as_numpy, COLUMNS)

    def program(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Trajectory:
        """``POST /v1/trajectories/program``: PTP, LIN and CIRC ``segments``, blended;
        ``raw["segments"]`` times each."""
        return self._call("trajectories/program", body, fields, as_numpy, COLUMNS)

    def retime(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Trajectory:
        """``POST /v1/trajectories/retime``: the time-optimal timing of a path through
        ``waypoints`` (``spline`` or ``blended`` corners)."""
        return self._call("trajectories/retime", body, fields, as_numpy, COLUMNS)

    def collision_free(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Trajectory:
        """``POST /v1/trajectories/collision_free``: a joint motion from ``start`` to ``goal``
        that plans around the ``environment``; ``raw["waypoints"]`` is its geometric path."""
        return self._call("trajectories/collision_free", body, fields, as_numpy, COLUMNS)

    def compare(
        self, body: Mapping[str, Any] | None = None, /, *, as_numpy: bool = False, **fields: Any
    ) -> Comparison:
        """``POST /v1/compare``: one Cartesian ``task`` through several ``methods``."""
        return self._call("compare", body, fields, as_numpy, COLUMNS)

    # --- batches ---------------------------------------------------------------------------

    def batch(
        self,
        items: Iterable[BatchItem | tuple[str, Mapping[str, Any]]],
        *,
        defaults: Mapping[str, Any] | None = None,
        as_numpy: bool = False,
    ) -> BatchStream:
        """``POST /v1/batch?stream=ndjson``: the items' results as they are done, in order.

        ``items`` are ``BatchItem(endpoint, body)`` or ``(endpoint, body)`` pairs (``endpoint``
        is a path after ``/v1/``, e.g. ``"trajectories/joint"``); ``defaults`` fills top-level
        fields of every item that takes them. Iterate the returned ``BatchStream`` (its
        ``summary`` is set at the end); a dropped connection resubmits the items not answered
        yet. Each result's ``value`` is what the endpoint's method returns, or ``error`` what it
        would raise."""
        pairs = [item if isinstance(item, BatchItem) else BatchItem(*item) for item in items]
        return BatchStream(self, pairs, dict(defaults or {}), as_numpy)
