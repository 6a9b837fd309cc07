"""What the steps of one request share, and every item of a batch: parsed robots, collision models.

A route may resolve its robot and build its collision model more than once (a Cartesian plan builds
the checker for the rate controller's clearance rows and again for the continuous check of its
answer), and the items of ``POST /v1/batch`` mostly send the same robot and the same environment
(cuRobo's ``plan_batch`` builds its robot and world models once for a whole batch). ``shared(kind,
key)`` decorates the service's one function for each (``service.convert.robot.resolve_robot``,
``service.convert.environment.collision_check``): while a ``Memo`` is active, a call whose ``key`` (the canonical
JSON of the robot reference and the environment) was seen returns the first call's result; outside
one it is a plain call. A call that raises stores nothing, so every error is raised again at its
own field.

``activate()`` makes one memo per request (``service.deps.request_deadline`` calls it) unless the
request runs inside a batch, whose memo every item's context inherits (``service.batch.run``). The
memo lives as long as the request (or the batch): at most one entry per distinct robot and
environment it sends.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable, Hashable
from contextvars import ContextVar
from typing import Any, ParamSpec, TypeVar

import orjson
from pydantic import BaseModel

P = ParamSpec("P")
T = TypeVar("T")


class Memo:
    """Results by ``(kind, key)``, with how often each kind was built and reused (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._values: dict[tuple[str, Hashable], Any] = {}
        self.built: dict[str, int] = {}
        self.reused: dict[str, int] = {}

    def get_or_build(self, kind: str, key: Hashable, build: Callable[[], T]) -> T:
        """The stored result of ``(kind, key)``, else ``build()`` stored (nothing when it raises).
        A ``None`` result (nothing to build: a robot without collision geometry) is stored but
        counted neither as built nor as reused."""
        with self._lock:
            if (kind, key) in self._values:
                value: T = self._values[kind, key]
                if value is not None:
                    self.reused[kind] = self.reused.get(kind, 0) + 1
                return value
        value = build()
        with self._lock:
            self._values.setdefault((kind, key), value)
            if value is not None:
                self.built[kind] = self.built.get(kind, 0) + 1
        return value

    def stats(self) -> dict[str, dict[str, int]]:
        """``{kind: {"built": n, "reused": m}}`` for every kind used."""
        kinds = sorted(set(self.built) | set(self.reused))
        return {k: {"built": self.built.get(k, 0), "reused": self.reused.get(k, 0)} for k in kinds}


MEMO: ContextVar[Memo | None] = ContextVar("memo", default=None)


def activate() -> Memo:
    """The memo of the current context; a new one (set in the context) when there is none."""
    memo = MEMO.get()
    if memo is None:
        memo = Memo()
        MEMO.set(memo)
    return memo


def canonical(value: Any) -> bytes:
    """Canonical JSON of a request value (a pydantic model, a dict, a string, None): keys sorted,
    so two items that send the same robot or environment get the same key."""
    if isinstance(value, BaseModel):
        value = value.model_dump(mode="json")
    return orjson.dumps(value, option=orjson.OPT_SORT_KEYS)


def shared(kind: str, key: Callable[P, Hashable]) -> Callable[[Callable[P, T]], Callable[P, T]]:
    """Decorator: inside an active memo, calls with the same ``key(*args, **kwargs)`` return the
    first call's result (``kind`` names the family in ``Memo.stats``); outside one, or when the
    key is None (nothing worth keeping), a plain call."""

    def decorate(fn: Callable[P, T]) -> Callable[P, T]:
        @functools.wraps(fn)
        def wrapper(*args: P.args, **kwargs: P.kwargs) -> T:
            memo = MEMO.get()
            k = None if memo is None else key(*args, **kwargs)
            if memo is None or k is None:
                return fn(*args, **kwargs)
            return memo.get_or_build(kind, k, lambda: fn(*args, **kwargs))

        return wrapper

    return decorate


def robot_key(ref: Any, *_: Any, **__: Any) -> Hashable:
    """Key of a robot reference (a name or an inline model); None for no robot."""
    return None if ref is None else canonical(ref)


def collision_key(robot: Any, env: Any, *_: Any, **__: Any) -> Hashable:
    """Key of a robot's collision model in an environment: the robot object (a registered robot
    or an inline one, named by its URDF's hash) and the environment's canonical JSON. The field
    where an error would be reported is not part of it: a model built once is valid everywhere."""
    return (robot.name, id(robot), canonical(env))
