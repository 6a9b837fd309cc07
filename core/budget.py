"""Wall-time budgets: a Deadline that long-running planners check between units of work."""

from __future__ import annotations

import time

from core.errors import TimeBudgetExceeded


class Deadline:
    """A point in monotonic time after which planning must stop.

    Args:
        seconds: Budget in [s] from now; ``None`` means no limit.
    """

    __slots__ = ("_end", "seconds")

    def __init__(self, seconds: float | None) -> None:
        self.seconds = seconds
        self._end = None if seconds is None else time.monotonic() + float(seconds)

    def remaining(self) -> float:
        """Seconds left (``inf`` without a limit, never negative)."""
        if self._end is None:
            return float("inf")
        return max(0.0, self._end - time.monotonic())

    def expired(self) -> bool:
        return self._end is not None and time.monotonic() >= self._end

    def check(self, where: str = "planning") -> None:
        """Raise TimeBudgetExceeded when the budget is spent; ``where`` names the stage."""
        if self.expired():
            raise TimeBudgetExceeded(
                f"{where} exceeded the wall-time budget of {self.seconds:g} s",
                extra={"budget_s": self.seconds},
            )


NO_DEADLINE = Deadline(None)
