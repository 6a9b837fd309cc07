"""Trajectory -> JSON bytes, the one place where numpy results become the wire format.

The response is encoded directly with orjson from numpy arrays (no per-point pydantic objects), so a
100,000-point trajectory costs one pass. ``time_format="ros"`` gives each ``time_from_start`` as a
ROS Duration ``{"sec", "nanosec"}`` converted through integer nanoseconds. ``?layout=columns`` gives
the samples as four arrays (``trajectory_columns``) instead of one object per point.

Every JSON answer of a planning route passes ``json_response``, which admits it first: the
request's deadline, a per-request cap on the estimated size (422 ``too_large``) and the worker's
budget of response bytes in flight (503 ``overloaded`` with ``Retry-After``), so a burst of large
answers cannot take a worker past its memory limit. The limits come from ``RESPONSE_POLICY``, which
``service.deps`` sets for each request from the settings.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import numpy as np
import orjson
from starlette.responses import Response, StreamingResponse
from starlette.types import Receive, Scope, Send

from core.budget import Deadline
from core.errors import Infeasible, TooLarge
from core.trajectory import Trajectory, check_duration
from service.admission import MemoryBudget, Reservation
from service.points_json import PointsJSON, encode_default, ros_parts

JSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY


def ros_durations(times: np.ndarray) -> list[dict[str, int]]:
    """Times in [s] -> ROS ``builtin_interfaces/Duration`` dicts through integer nanoseconds
    (``ros_parts``: times outside ``[0, MAX_DURATION]`` are refused, never wrapped)."""
    sec, nanosec = ros_parts(times)
    return [
        {"sec": int(s), "nanosec": int(n)}
        for s, n in zip(sec.tolist(), nanosec.tolist(), strict=True)
    ]


def trajectory_points(traj: Trajectory, time_format: str = "float") -> list[dict[str, Any]]:
    """The ROS-shaped ``points`` list of a trajectory.

    The arrays of each point are row views of the trajectory's numpy arrays, which orjson writes
    (``OPT_SERIALIZE_NUMPY``) exactly as it writes Python floats: no Python float objects, so a
    100,000-point, 64-joint plan peaks at half the memory and encodes 4x faster than ``tolist()``.
    """
    times: list[Any] = ros_durations(traj.times) if time_format == "ros" else traj.times.tolist()
    pos, vel, acc = (
        np.ascontiguousarray(a, dtype=np.float64)
        for a in (traj.positions, traj.velocities, traj.accelerations)
    )
    return [
        {"time_from_start": t, "positions": p, "velocities": v, "accelerations": a}
        for t, p, v, a in zip(times, pos, vel, acc, strict=True)
    ]


def base_diagnostics(traj: Trajectory, method: str, compute_time_ms: float) -> dict[str, Any]:
    """Diagnostics every trajectory response carries."""
    return {
        "method": method,
        "duration": traj.duration,
        "compute_time_ms": compute_time_ms,
        "peak_velocity": traj.peak_velocity,
        "peak_acceleration": traj.peak_acceleration,
        "peak_jerk": traj.peak_jerk,
        "warnings": [],
    }


def trajectory_columns(traj: Trajectory, time_format: str = "float") -> dict[str, Any]:
    """The columnar layout: ``time_from_start`` ``(n,)`` and ``positions``/``velocities``/
    ``accelerations`` ``(n, dof)`` as numpy arrays, which orjson writes in one pass each."""
    times: Any = ros_durations(traj.times) if time_format == "ros" else _f64(traj.times)
    return {
        "time_from_start": times,
        "positions": _f64(traj.positions),
        "velocities": _f64(traj.velocities),
        "accelerations": _f64(traj.accelerations),
    }


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def trajectory_body(
    traj: Trajectory,
    diagnostics: dict[str, Any],
    time_format: str = "float",
    layout: str | None = None,
    *,
    encoded: bool = False,
    **extra: Any,
) -> dict[str, Any]:
    """The response document: ``joint_names``, the samples, ``diagnostics`` and any extra keys.

    Args:
        layout: ``points`` (default: ROS-shaped ``points``, one object per sample) or ``columns``
            (``"layout": "columns"`` and the four arrays of ``trajectory_columns`` at the top
            level); ``None`` takes the request's ``?layout=`` (``RESPONSE_POLICY``).
        encoded: ``points`` as a ``PointsJSON`` (the same bytes from ``json_response``, written
            straight from the arrays) instead of a list of dicts; for a document only encoded.
    """
    layout = layout or current_policy().layout
    body: dict[str, Any] = {"joint_names": list(traj.joint_names)}
    if layout == "columns":
        body["layout"] = "columns"
        body.update(trajectory_columns(traj, time_format))
    else:
        body["points"] = (
            PointsJSON(traj, time_format) if encoded else trajectory_points(traj, time_format)
        )
    body["diagnostics"] = diagnostics
    body.update(extra)
    return body


def check_finite(traj: Trajectory) -> None:
    """Refuse to emit a non-finite number (a planner bug, never a client's fault) or a trajectory
    longer than ``MAX_DURATION`` (``check_duration``: 422 ``infeasible``). Every trajectory route
    passes here, so no planned duration escapes the bound, whatever field made it long."""
    for name in ("times", "positions", "velocities", "accelerations"):
        if not np.all(np.isfinite(getattr(traj, name))):
            raise Infeasible(f"planning produced a non-finite {name} value; the plan is refused")
    check_duration(traj.duration)


STREAM_BYTES = 16 * 1024 * 1024
"""A trajectory document estimated (``estimate_bytes``) above this many bytes is streamed, so a
worker never holds the whole encoded document of a large trajectory (hundreds of MB); a smaller one
is encoded in one call (streaming costs a thread-pool hop per chunk: a 10,000-point, 6-joint
spline, 4.4 MB, took 9.5 ms streamed and 3.5 ms whole in columns)."""
STREAM_POINTS = 5_000
"""Samples per chunk of a streamed document."""
CHUNK_BYTES = 1024 * 1024
"""A streamed document's pieces are sent in runs of at least this many bytes [bytes]."""

BYTES_PER_NUMBER = 24
"""Upper estimate of one encoded float64 in [bytes]: 17 significant digits, sign, point, exponent
and the comma."""
BYTES_PER_SAMPLE = 128
"""Upper estimate of the per-sample framing in [bytes]: the keys of a ROS-shaped point and its time."""
COLUMNS = ("time_from_start", "positions", "velocities", "accelerations")


@dataclass(frozen=True)
class ResponsePolicy:
    """What the current request allows its response (set per request by ``service.deps``).

    Attributes:
        layout: ``points`` or ``columns``.
        max_bytes: Largest estimated response in [bytes]; ``None``: no cap.
        budget_bytes: Estimated response bytes a worker holds in flight in [bytes]; ``None``: no budget.
        deadline: The request's deadline, checked before encoding; ``None``: none.
    """

    layout: str = "points"
    max_bytes: int | None = None
    budget_bytes: int | None = None
    deadline: Deadline | None = None


DEFAULT_POLICY = ResponsePolicy()
RESPONSE_POLICY: ContextVar[ResponsePolicy | None] = ContextVar("response_policy", default=None)


def current_policy() -> ResponsePolicy:
    """The current request's policy (``DEFAULT_POLICY``, no limits, outside a request)."""
    return RESPONSE_POLICY.get() or DEFAULT_POLICY


RESPONSE_BUDGET = MemoryBudget("response memory")
"""Estimated bytes of the answers this worker holds (``Reservation`` until sent)."""


def estimate_bytes(body: Any) -> int:
    """Upper estimate of the encoded size of a response's samples in [bytes]:
    samples x (3 x joints x ``BYTES_PER_NUMBER`` + ``BYTES_PER_SAMPLE``), summed over every
    trajectory in the document (``/v1/compare`` rows included); 0 for a body without samples."""
    if isinstance(body, list):
        return sum(estimate_bytes(item) for item in body)
    if not isinstance(body, dict):
        return 0
    n = _samples(body)
    total = 0
    if n:
        dof = len(body.get("joint_names") or ()) or _row_width(body)
        total = n * (3 * dof * BYTES_PER_NUMBER + BYTES_PER_SAMPLE)
    for key in ("results", "trajectory"):
        if key in body:
            total += estimate_bytes(body[key])
    return total


def _samples(body: dict[str, Any]) -> int:
    points = body.get("points")
    if isinstance(points, list | PointsJSON):
        return len(points)
    times = body.get("time_from_start")
    return len(times) if isinstance(times, list | np.ndarray) else 0


def _row_width(body: dict[str, Any]) -> int:
    positions = body.get("positions")
    if isinstance(positions, np.ndarray) and positions.ndim == 2:
        return int(positions.shape[1])
    points = body.get("points") or [{}]
    if isinstance(points, PointsJSON):
        return points.dof
    return len(points[0].get("positions", ())) if isinstance(points[0], dict) else 0


def json_response(body: Any, status_code: int = 200) -> Response:
    """``body`` as JSON, admitted first (limits from ``current_policy()``).

    A trajectory document past the request's deadline is 422 ``time_budget_exceeded``; an estimate
    (``estimate_bytes``) over the per-request cap is 422 ``too_large``; over the worker's budget of
    response bytes in flight, 503 ``overloaded`` with ``Retry-After``. The reservation is returned
    when the response has been sent. A trajectory document estimated above ``STREAM_BYTES`` is
    streamed in chunks of ``STREAM_POINTS`` samples (the same bytes)."""
    policy = current_policy()
    if policy.deadline is not None and isinstance(body, dict) and _samples(body):
        # A trajectory document only: /v1/compare reports a method's timeout in its row.
        policy.deadline.check("planning")
    estimate = estimate_bytes(body)
    if policy.max_bytes is not None and estimate > policy.max_bytes:
        raise TooLarge(
            f"the response would take about {estimate} bytes; at most {policy.max_bytes} are "
            "allowed (fewer samples, a longer sample_period or fewer joints)",
            extra={"estimated_bytes": estimate, "limit_bytes": policy.max_bytes},
        )
    reservation = RESPONSE_BUDGET.reserve(estimate, policy.budget_bytes) if estimate else None
    response: Response
    if isinstance(body, dict) and estimate > STREAM_BYTES and _samples(body) > STREAM_POINTS:
        response = _AdmittedStreamingResponse(
            _coalesced(_stream(body)), status_code=status_code, media_type="application/json"
        )
    else:
        response = _AdmittedResponse(
            orjson.dumps(body, default=encode_default, option=JSON_OPTIONS),
            status_code=status_code,
            media_type="application/json",
        )
    if reservation is not None:
        response.reservation = reservation
        weakref.finalize(response, reservation.release)  # a response never sent
    return response


class _ReleasesReservation:
    """Mixed into a starlette response: returns its reservation once it is sent (or fails to be)."""

    reservation: Reservation | None = None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        try:
            await super().__call__(scope, receive, send)  # type: ignore[misc]
        finally:
            if self.reservation is not None:
                self.reservation.release()


class _AdmittedResponse(_ReleasesReservation, Response):
    """A whole response that returns its reservation once it is sent."""


class _AdmittedStreamingResponse(_ReleasesReservation, StreamingResponse):
    """A streamed response that returns its reservation once it is sent."""


def _coalesced(pieces: Iterator[bytes]) -> Iterator[bytes]:
    """The same bytes in runs of at least ``CHUNK_BYTES`` (each run costs starlette a thread-pool
    hop and uvicorn a write; a document's framing alone is a dozen tiny pieces)."""
    pending: list[bytes] = []
    size = 0
    for piece in pieces:
        pending.append(piece)
        size += len(piece)
        if size >= CHUNK_BYTES:
            yield b"".join(pending)
            pending, size = [], 0
    if pending:
        yield b"".join(pending)


def _stream(body: dict[str, Any]) -> Iterator[bytes]:
    """The bytes of ``orjson.dumps(body)``, with ``points`` (or each column) written a chunk of
    ``STREAM_POINTS`` samples at a time."""
    yield b"{"
    for i, (key, value) in enumerate(body.items()):
        yield (b"," if i else b"") + orjson.dumps(key) + b":"
        if key != "points" and not (key in COLUMNS and len(value) > STREAM_POINTS):
            yield orjson.dumps(value, default=encode_default, option=JSON_OPTIONS)
            continue
        yield b"["
        for start in range(0, len(value), STREAM_POINTS):
            if isinstance(value, PointsJSON):
                chunk = value.encode(start, start + STREAM_POINTS)
            else:
                chunk = orjson.dumps(value[start : start + STREAM_POINTS], option=JSON_OPTIONS)
            yield (b"," if start else b"") + chunk[1:-1]
        yield b"]"
    yield b"}"
