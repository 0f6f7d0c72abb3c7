"""rclpy's logging without its per-call source lookup.

rclpy's ``logger.info`` finds its caller through ``inspect.getframeinfo`` on every call (it reads
the caller's source line to key its once/throttle filters): about 0.5-0.8 ms a line here, paid
by every plan request that logs its outcome. Filters are not needed on these lines, so this
hands the text to rcutils directly, as rclpy itself does at the end of that call (so stderr and
/rosout get it the same way), with the caller's function, file and line from ``sys._getframe``.
"""
from __future__ import annotations

import sys
import time
from typing import Any, Callable, Hashable

from rclpy.impl.implementation_singleton import rclpy_implementation as rcutils_binding
from rclpy.logging import LoggingSeverity

__all__ = ["SEVERITIES", "Throttle", "log"]

SEVERITIES = {"debug": LoggingSeverity.DEBUG, "info": LoggingSeverity.INFO, "warning": LoggingSeverity.WARN,
              "warn": LoggingSeverity.WARN, "error": LoggingSeverity.ERROR, "fatal": LoggingSeverity.FATAL}


def log(logger: Any, level: str, text: str, depth: int = 1,
        defer: Callable[[Callable[[], None]], bool] | None = None) -> bool:
    """Log ``text`` at ``level`` ("debug", "info", "warning", "error", "fatal") on the rclpy
    ``logger``, as coming from the caller ``depth`` frames up; False when the level is off. With
    ``defer`` (dedicated_service.after_response), the line is written when ``defer`` runs it, if
    it takes it (its time stamp is then that moment's)."""
    severity = SEVERITIES[level]
    if not logger.is_enabled_for(severity):
        return False
    frame = sys._getframe(depth)
    line = (severity, logger.name, text, frame.f_code.co_name, frame.f_code.co_filename, frame.f_lineno)
    if defer is None or not defer(lambda: rcutils_binding.rclpy_logging_rcutils_log(*line)):
        rcutils_binding.rclpy_logging_rcutils_log(*line)
    return True


class Throttle:
    """At most one line per ``period`` s of each kind: ``if throttle(key): log(...)``. rclpy's
    ``throttle_duration_sec`` looks the caller up before it filters, so a throttled line still
    costs that lookup on every call (a command stream at 100 Hz logging through it took a tenth of
    a core in mock_controllers)."""

    def __init__(self, period: float = 1.0) -> None:
        self.period = period
        self._last: dict[Hashable, float] = {}

    def __call__(self, key: Hashable) -> bool:
        now = time.monotonic()
        if now - self._last.get(key, -1e18) < self.period:
            return False
        self._last[key] = now
        return True
