"""Time for the nodes that wait (Sleep, Delay, Timeout) and for the tree's tick loop.

A tree reads time only through its clock, so a test can hand it a FakeClock and step time
instead of sleeping: Timeout and Delay traces are then exact and never flaky.
"""
from __future__ import annotations

import threading
import time


class SystemClock:
    """Monotonic wall time; ``sleep`` returns early when the tree is woken up."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float, wake_up: threading.Event) -> bool:
        """Wait up to ``seconds``; True if woken up (the event is then cleared)."""
        woken = wake_up.wait(max(0.0, seconds))
        if woken:
            wake_up.clear()
        return woken


class FakeClock:
    """Time that only moves when told to: ``advance(dt)``, or ``sleep`` (which jumps ahead)."""

    def __init__(self, start: float = 0.0):
        self._now = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        return self._now

    def advance(self, seconds: float) -> None:
        with self._lock:
            self._now += float(seconds)

    def set(self, now: float) -> None:
        with self._lock:
            self._now = float(now)

    def sleep(self, seconds: float, wake_up: threading.Event) -> bool:
        if wake_up.is_set():
            wake_up.clear()
            return True
        self.advance(seconds)
        return False


Clock = SystemClock | FakeClock


class WakeUpSignal:
    """How nodes ask the tree to tick again: now (``emit``, any thread) or at a time
    (``wake_at``, for Sleep, Delay and Timeout), so the tick loop need not poll."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self._deadline: float | None = None
        self._lock = threading.Lock()

    def emit(self) -> None:
        self.event.set()

    def wake_at(self, when: float) -> None:
        with self._lock:
            if self._deadline is None or when < self._deadline:
                self._deadline = when

    def clear_due(self, clock: Clock) -> None:
        """Forget the wake-ups a tick about to start answers: those asked for before it."""
        self.event.clear()
        with self._lock:
            if self._deadline is not None and self._deadline <= clock.now():
                self._deadline = None

    def consume(self, clock: Clock) -> bool:
        """True (and cleared) if a wake-up was asked for by now; never waits."""
        if self.event.is_set():
            self.event.clear()
            return True
        with self._lock:
            if self._deadline is not None and self._deadline <= clock.now():
                self._deadline = None
                return True
        return False

    def wait(self, clock: Clock, timeout: float) -> bool:
        """Sleep up to ``timeout`` on ``clock``, less if a node asked to be woken earlier."""
        with self._lock:
            deadline = self._deadline
            if deadline is not None:
                remaining = deadline - clock.now()
                if remaining <= 0.0:
                    self._deadline = None
                    return True
                if remaining <= timeout:
                    timeout = remaining
                    self._deadline = None
        return clock.sleep(timeout, self.event)
