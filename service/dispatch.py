"""Where a route's planning runs: on the event loop when it is tiny, else in the thread pool.

A plain ``def`` route costs a hop to the thread pool and back (about 0.15 ms of a 1.5 ms round
trip for a 1000-point quintic, measured with ``bench/http_load.py``). A plan that is pure joint math
(no robot model to load, no collision check) with a small, known answer takes less CPU than that
hop is worth keeping the loop free for, so it runs inline; anything else (a robot, an environment,
an unknown or large sample count) runs in the pool, so the loop keeps serving other connections.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from starlette.concurrency import run_in_threadpool

T = TypeVar("T")

INLINE_NUMBERS = 20_000
"""Most numbers (samples x joints x 3) of an answer planned on the event loop: a 1000-point,
6-joint quintic (18,000) plans and encodes in about 0.6 ms of CPU."""


def answer_numbers(body: Any, dof: int) -> int | None:
    """Numbers in the answer of a joint-space request with ``samples`` or ``duration`` and
    ``sample_period``, when at most ``INLINE_NUMBERS``; ``None`` when more, when only planning
    tells (a time-optimal duration) or when a robot or an environment makes the plan more than
    joint math."""
    if getattr(body, "robot", None) is not None or getattr(body, "environment", None) is not None:
        return None
    samples = getattr(body, "samples", None)
    if samples is None:
        duration, period = getattr(body, "duration", None), getattr(body, "sample_period", None)
        if duration is None or period is None:
            return None
        samples = duration / period + 2.0  # a subnormal period overflows to inf: never inline
    numbers = 3.0 * dof * samples
    return int(numbers) if numbers <= INLINE_NUMBERS else None


async def run_plan(plan: Callable[[], T], numbers: int | None) -> T:
    """``plan()`` inline when ``numbers`` is known and at most ``INLINE_NUMBERS``, else in the
    thread pool (with the request's context variables either way)."""
    if numbers is not None and numbers <= INLINE_NUMBERS:
        return plan()
    return await run_in_threadpool(plan)
