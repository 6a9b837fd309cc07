"""Admission by working memory: a worker takes a request only while the memory it will need fits.

The response budget (``service.encoding``) counts the bytes of answers in flight; a request's
working memory is counted here: the arrays of planning (samples x joints) and of the continuous
collision check (points x pairs), which reached +504 MiB for one 37 kB joint request (256 obstacles
hugging a 30,000-sample UR5 turn) and 3.4-3.8 GiB for 8 of them in one worker.

- ``admit`` (a dependency of every computing router) estimates what the body asks for
  (``estimate``) and reserves it in the worker's ``WORKING_MEMORY`` before anything is planned; a
  reservation that does not fit ``TRAJ_MEMORY_BUDGET_BYTES`` while other requests hold memory is
  503 ``overloaded`` with ``Retry-After`` (alone, a request is always admitted: the per-request
  caps, points and check entries, bound it). It is returned when the request ends, however.
- A plan whose sample count only planning tells (a time-optimal or speed-limited duration) is
  admitted again when its grid is drawn: ``core.trajectory.sample_times`` calls the hook set here
  (``SAMPLING_ADMISSION``) with the count, and the reservation grows to the samples' planning and
  check memory, or the request is 503 before the arrays exist.

The check's estimate is ``CHECK_BYTES_PER_ENTRY`` per (key point, pair) entry of
``robots.collision.CollisionChecker.check_path``, capped by its ``MAX_KEY_ENTRIES``. Note for the
integrator: once the continuous check's working memory is bounded by construction
(``CHECK_WORKING_BYTES`` of the robots module), ``check_bytes`` is the smaller of the two.
"""

from __future__ import annotations

import math
import threading
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import Any

from fastapi import Request

from core.cartesian.task import MAX_TICKS
from core.errors import PlanningError
from core.trajectory import DEFAULT_SAMPLE_PERIOD, SAMPLING_ADMISSION
from robots import registry
from robots.collision import CHECK_WORKING_BYTES, KEY_STEP, MAX_CAPSULES, MAX_KEY_ENTRIES
from robots.geometry import ROBOT_GEOMETRY
from service.errors import Overloaded

RETRY_AFTER_S = 1
"""``Retry-After`` [s] of a request refused for memory."""
REQUEST_BYTES = 1024 * 1024
"""Working memory of any request before its arrays [bytes]: parsing, the model objects."""
CHECK_BYTES_PER_ENTRY = 160
"""Working memory of the continuous check per (key point, pair) entry [bytes]: 3.39 M entries (the
30,000-sample UR5 turn among 256 obstacles, 1806 pairs) took +447 MiB, 138 bytes each."""
JOINT_SAMPLE_BYTES = (256, 48)
"""Planning memory of a joint-space plan per sample [bytes]: constant + per joint (100,000 samples
took +48 MiB for 6 joints, +264 MiB for 64: 480 and 2,640 bytes a sample)."""
CARTESIAN_SAMPLE_BYTES = (2048, 512)
"""Planning memory of a Cartesian or program plan per sample [bytes]: constant + per joint (a
100,000-sample UR5 line took +393 MiB sampled, +373 MiB with bounded_deviation_nlp: 4.1 KB)."""
RATE_TICK_BYTES = 128
"""Memory of a resolved-rate run per control tick [bytes] (900,000 ticks took +96 MiB)."""
JOINT_ROUTES = ("/v1/trajectories/joint", "/v1/trajectories/spline")
"""Routes whose plans are joint math (``JOINT_SAMPLE_BYTES``); every other trajectory route is
counted as a Cartesian one (``CARTESIAN_SAMPLE_BYTES``), the costlier."""
SHAPE_TAGS = ("<box", "<sphere", "<cylinder", "<capsule")


class MemoryBudget:
    """Estimated bytes held by the requests of this worker (thread-safe; one per process).

    Args:
        what: What the bytes are, for the 503's detail (``working memory``, ``response memory``).
    """

    def __init__(self, what: str = "memory") -> None:
        self._lock = threading.Lock()
        self.in_flight = 0
        self.what = what

    def reserve(self, nbytes: int, budget: int | None) -> Reservation:
        """Admit ``nbytes`` [bytes], or raise ``Overloaded`` (503) when others hold the budget.

        A reservation is admitted while nothing else is in flight even above ``budget``, so the
        per-request caps, not the budget, bound one request."""
        reservation = Reservation(self, 0)
        reservation.grow_to(nbytes, budget)
        return reservation

    def _grow(self, nbytes: int, by: int, budget: int | None) -> None:
        with self._lock:
            others = self.in_flight - nbytes
            if budget is not None and others and self.in_flight + by > budget:
                raise Overloaded(
                    f"the worker's {self.what} budget ({budget} bytes) is in use; this request "
                    f"needs about {nbytes + by} bytes",
                    retry_after_s=RETRY_AFTER_S,
                )
            self.in_flight += by

    def _release(self, nbytes: int) -> None:
        with self._lock:
            self.in_flight -= nbytes


class Reservation:
    """Bytes held in a ``MemoryBudget`` until ``release()`` (idempotent)."""

    __slots__ = ("__weakref__", "_budget", "nbytes")

    def __init__(self, budget: MemoryBudget, nbytes: int) -> None:
        self._budget: MemoryBudget | None = budget
        self.nbytes = nbytes

    def grow_to(self, nbytes: int, budget: int | None) -> None:
        """Hold at least ``nbytes`` [bytes] (``Overloaded`` when that does not fit ``budget``)."""
        if self._budget is not None and nbytes > self.nbytes:
            self._budget._grow(self.nbytes, nbytes - self.nbytes, budget)
            self.nbytes = nbytes

    def release(self) -> None:
        budget, self._budget = self._budget, None
        if budget is not None:
            budget._release(self.nbytes)


WORKING_MEMORY = MemoryBudget("working memory")


@dataclass(frozen=True)
class Demand:
    """What a request body asks of a worker's memory, before planning.

    Attributes:
        dof: Joints of the plan (0: unknown).
        points: Returned samples when the body fixes them, else None (only planning tells).
        pairs: Upper bound on the pairs the continuous check evaluates (0: no check).
        sample_bytes: Planning memory per sample [bytes].
        fixed_bytes: Memory known before any sample [bytes] (the request, a rate run's ticks).
    """

    dof: int
    points: int | None
    pairs: int
    sample_bytes: int
    fixed_bytes: int

    def bytes_for(self, points: int) -> int:
        """Working memory [bytes] of a plan of ``points`` samples."""
        return self.fixed_bytes + points * self.sample_bytes + check_bytes(points, self.pairs)

    def at_entry(self) -> int:
        """What is known before planning [bytes]."""
        return self.bytes_for(self.points) if self.points is not None else self.fixed_bytes


def check_bytes(points: int, pairs: int) -> int:
    """Working memory [bytes] of a continuous check of ``points`` returned points against
    ``pairs`` pairs: ``CHECK_BYTES_PER_ENTRY`` per key entry (every ``KEY_STEP``-th point x pair),
    at most ``MAX_KEY_ENTRIES`` entries (more is refused by the check itself), and never more
    than ``CHECK_WORKING_BYTES``, the bound the check keeps by construction."""
    entries = min(MAX_KEY_ENTRIES, math.ceil(points / KEY_STEP) * pairs)
    return min(entries * CHECK_BYTES_PER_ENTRY, CHECK_WORKING_BYTES)


def _get(node: Any, *path: str) -> Any:
    for key in path:
        node = node.get(key) if isinstance(node, dict) else None
    return node


def _number(value: Any) -> float | None:
    is_number = isinstance(value, int | float) and not isinstance(value, bool)
    return float(value) if is_number and math.isfinite(value) and value > 0 else None


def _robot(ref: Any) -> tuple[int, int]:
    """Joints (0: unknown) and collision primitives (upper bound) of a request's ``robot``."""
    if isinstance(ref, str):
        geometry = ROBOT_GEOMETRY.get(ref)
        try:
            dof = registry.get(ref).dof
        except PlanningError:  # an unknown name: the route answers 404
            return 0, 0
        return dof, 0 if geometry is None else len(geometry.capsules)
    urdf = _get(ref, "urdf")
    if not isinstance(urdf, str):
        return 0, 0
    joints = urdf.count("<joint")
    return joints, min(MAX_CAPSULES, sum(urdf.count(tag) for tag in SHAPE_TAGS))


def _dof(body: dict[str, Any], robot_dof: int) -> int:
    """The robot's joints, else the length of the first joint array the body gives (0: none)."""
    waypoints = body.get("waypoints")
    first = waypoints[0] if isinstance(waypoints, list) and waypoints else None
    for array in (_get(body, "start", "positions"), body.get("positions"), first):
        if isinstance(array, list):
            return robot_dof or len(array)
    return robot_dof


def _points(body: dict[str, Any], max_points: int) -> int | None:
    samples = body.get("samples")
    if isinstance(samples, int) and not isinstance(samples, bool) and samples > 0:
        return min(samples, max_points)
    duration, period = _number(body.get("duration")), _number(body.get("sample_period"))
    if duration is None:
        return None
    count = duration / (period or DEFAULT_SAMPLE_PERIOD) + 2.0  # inf for a subnormal period
    return min(max_points, math.ceil(count)) if count < max_points else max_points


def estimate(body: Any, route: str, max_points: int) -> Demand:
    """What the JSON ``body`` of a request to the route ``route`` (its path template) asks of a
    worker's memory; ``body`` may be anything (a malformed one costs nothing: it fails validation)."""
    if not isinstance(body, dict):
        return Demand(0, 0, 0, 0, REQUEST_BYTES)
    nested = body.get("task")  # /v1/compare: the Cartesian request is its task
    task: dict[str, Any] = nested if isinstance(nested, dict) else body
    robot_dof, capsules = _robot(task.get("robot"))
    dof = _dof(task, robot_dof)
    given = task.get("environment")
    environment: dict[str, Any] = given if isinstance(given, dict) else {}
    obstacles = environment.get("obstacles")
    count = len(obstacles) if isinstance(obstacles, list) else 0
    self_pairs = capsules * (capsules - 1) // 2 if environment.get("self_collision", True) else 0
    pairs = capsules * count + self_pairs
    constant, per_joint = JOINT_SAMPLE_BYTES if route in JOINT_ROUTES else CARTESIAN_SAMPLE_BYTES
    fixed = REQUEST_BYTES
    if str(task.get("method", "")).startswith("resolved_rate"):
        duration, period = _number(task.get("duration")), _number(task.get("control_period"))
        ticks = MAX_TICKS if duration is None else 2 * duration / (period or 1e-3)
        fixed += int(min(MAX_TICKS, ticks)) * RATE_TICK_BYTES
    methods = body.get("methods")
    kept = len(methods) if isinstance(methods, list) and task is not body else 1
    sample_bytes = constant + per_joint * dof + (kept - 1) * 24 * dof  # /v1/compare keeps rows
    points = 1 if route.startswith("/v1/robots") or route.endswith("distance") else None
    return Demand(dof, points or _points(task, max_points), pairs, sample_bytes, fixed)


async def admit(request: Request) -> AsyncIterator[Reservation]:
    """Reserve the request's working memory (503 ``overloaded`` when it does not fit), grow it
    when planning draws its sample grid, and return it when the request ends."""
    settings = request.app.state.settings
    route = getattr(request.scope.get("route"), "path", "")
    try:
        body = await request.json() if request.method == "POST" else None
    except ValueError:  # not JSON: validation answers it
        body = None
    demand = estimate(body, route, settings.max_points)
    budget = settings.memory_budget_bytes
    reservation = WORKING_MEMORY.reserve(demand.at_entry(), budget)
    SAMPLING_ADMISSION.set(_on_sampling(reservation, demand, budget))
    try:
        yield reservation
    finally:
        reservation.release()


def _on_sampling(reservation: Reservation, demand: Demand, budget: int) -> Callable[[int], None]:
    def grow(points: int) -> None:
        reservation.grow_to(demand.bytes_for(points), budget)

    return grow
