"""When to try a request again, and how long to wait first.

A request is tried again on 503 ``overloaded`` (the service's own answer when it is at capacity)
and when the connection fails (refused, reset, closed before an answer), never on any other answer:
every endpoint computes without side effects, so a second try is safe. The wait before retry ``k``
(0-based) is exponential, ``backoff_s * 2**k`` capped at ``max_backoff_s``, with jitter (a uniform
draw in its upper half), so many clients do not come back together; when the service sends
``Retry-After``, the wait is that plus a jitter of up to one backoff step. A ``Retry-After`` above
``max_retry_after_s`` is not waited for: the error is raised at once.
"""

from __future__ import annotations

import email.utils
import random
import time
from dataclasses import dataclass

import httpx

RETRYABLE_TRANSPORT = (
    httpx.ConnectError,
    httpx.ConnectTimeout,
    httpx.RemoteProtocolError,
    httpx.ReadError,
    httpx.WriteError,
)
"""Connection failures worth a second try (a read timeout is not one: the service is working)."""


@dataclass(frozen=True)
class RetryPolicy:
    """Attributes:
    attempts: Tries in all (1: never retry).
    backoff_s: Wait before the first retry [s], doubled for each next one.
    max_backoff_s: Longest wait between tries [s] (without ``Retry-After``).
    max_retry_after_s: Longest ``Retry-After`` honoured [s]; longer raises at once.
    """

    attempts: int = 4
    backoff_s: float = 0.2
    max_backoff_s: float = 5.0
    max_retry_after_s: float = 30.0

    def delay(self, retry: int, retry_after: float | None, rng: random.Random) -> float | None:
        """Seconds to wait before retry ``retry`` (0-based); None: do not retry."""
        if retry + 1 >= self.attempts:
            return None
        step = min(self.max_backoff_s, self.backoff_s * 2.0**retry)
        if retry_after is not None:
            if retry_after > self.max_retry_after_s:
                return None
            return retry_after + rng.uniform(0.0, step)
        return rng.uniform(step / 2, step)


NO_RETRY = RetryPolicy(attempts=1)


def retry_after_seconds(value: str | None) -> float | None:
    """``Retry-After`` in [s]: delay-seconds or an HTTP date; None when absent or unreadable."""
    if not value:
        return None
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        when = email.utils.parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    return max(0.0, when.timestamp() - time.time())
