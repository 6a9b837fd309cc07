"""service.dispatch: tiny robot-less joint plans run on the event loop, everything else in the pool."""

from __future__ import annotations

import asyncio
import threading
from types import SimpleNamespace

from service.dispatch import INLINE_NUMBERS, answer_numbers, run_plan


def body(**fields):
    base = {"robot": None, "environment": None, "samples": None, "duration": None}
    return SimpleNamespace(**{**base, "sample_period": None, **fields})


def test_answer_numbers():
    assert answer_numbers(body(samples=1000), 6) == 18_000
    assert answer_numbers(body(duration=2.0, sample_period=0.01), 6) == int(3 * 6 * 202.0)
    assert answer_numbers(body(samples=1200), 6) is None  # 21,600 > INLINE_NUMBERS
    assert (
        answer_numbers(
            body(samples=10),
            6,
        )
        == 180
    )
    assert answer_numbers(body(samples=10, robot="ur5"), 6) is None  # a robot: collision checks
    assert answer_numbers(body(samples=10, environment={}), 6) is None
    assert answer_numbers(body(duration=2.0), 6) is None  # default period: only planning tells
    assert answer_numbers(body(), 6) is None  # time-optimal
    # a subnormal period overflows duration / period to inf: not inline, and no OverflowError
    assert answer_numbers(body(duration=1.0, sample_period=5e-324), 6) is None
    assert 3 * 6 * 1000 <= INLINE_NUMBERS < 3 * 6 * 1200


def test_run_plan_runs_small_plans_on_the_loop_and_others_in_the_pool():
    async def where(numbers):
        loop_thread = threading.get_ident()
        ran_on = await run_plan(threading.get_ident, numbers)
        return ran_on == loop_thread

    assert asyncio.run(where(INLINE_NUMBERS)) is True
    assert asyncio.run(where(INLINE_NUMBERS + 1)) is False
    assert asyncio.run(where(None)) is False
