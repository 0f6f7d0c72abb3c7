"""Waiting for a condition by polling it, for code that has no event to wait on (a bench watching
a controller, a test watching a node): one loop instead of one per caller."""
from __future__ import annotations

import time
from typing import Callable, TypeVar

__all__ = ["wait_until"]

_T = TypeVar("_T")


def wait_until(predicate: Callable[[], _T], timeout: float, period: float = 0.05) -> _T:
    """Poll ``predicate`` every ``period`` s until it answers something true or ``timeout`` s
    have passed; its last answer (asked once more at the deadline)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(period)
    return predicate()
