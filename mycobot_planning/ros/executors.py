"""rclpy's MultiThreadedExecutor without its busy loop: rclpy issue #1452, fixed upstream by
rclpy PR #1547 (November 2025), not in the rclpy 7.1.5 that ros-jazzy-rclpy 7.1.6 (pinned in
scripts/requirements.txt) installs.

rclpy's executor yields a handler again while it waits in the thread pool's queue, not yet
started (its loop re-yields every task that is "not executing and not done"), and hands it to
the pool again each time. Under the GIL the spinning thread then keeps the interpreter from the
worker that would start it: measured on the planning_server, a 5 ms JSON get_planning_scene took
5-370 ms once this began, the executor spun ~4,400 times a second with ~350 stale entries in its
future list, and the process used a whole core for 20 requests a second. Here a handler goes to
the pool once; while it waits there, the spinning thread waits for it to start (the GIL free)
instead of queueing it again. A task that has started and is suspended in an ``await`` is handed
over again when re-yielded, as rclpy does.
"""
from __future__ import annotations

import threading
from typing import Any, Callable

from rclpy.executors import ConditionReachedException, ExternalShutdownException, ShutdownException
from rclpy.executors import MultiThreadedExecutor as _RclpyMultiThreadedExecutor
from rclpy.executors import TimeoutException

__all__ = ["MultiThreadedExecutor"]

#: How long the spinning thread waits for a queued handler to start before it looks again (all
#: workers busy: nothing else could run before one is free either).
QUEUED_WAIT_S = 0.05


class MultiThreadedExecutor(_RclpyMultiThreadedExecutor):
    """rclpy's MultiThreadedExecutor; a handler is queued in the pool once (see the module)."""

    def __init__(self, num_threads: int | None = None, *, context: Any = None) -> None:
        super().__init__(num_threads, context=context)
        self._queued: dict[Any, threading.Event] = {}  # handed to the pool, not started: set on start
        self._queued_lock = threading.Lock()

    def _spin_once_impl(self, timeout_sec: Any = None, wait_condition: Callable[[], bool] = lambda: False) -> None:
        try:
            handler, _, _ = self.wait_for_ready_callbacks(timeout_sec, None, wait_condition)
        except (ExternalShutdownException, ShutdownException, TimeoutException, ConditionReachedException):
            return
        with self._queued_lock:
            started = self._queued.get(handler)
            queued = started is not None
            if not queued:
                started = self._queued[handler] = threading.Event()
        if queued:
            started.wait(QUEUED_WAIT_S)  # a worker takes it soon: let it, rather than queue it again
            return
        self._executor.submit(self._start, handler, started)
        self._futures.append(handler)
        for future in self._futures[:]:
            if future.done():
                self._futures.remove(future)
                future.result()  # a callback's exception leaves spin(), as in rclpy

    def _start(self, handler: Any, started: threading.Event) -> None:
        with self._queued_lock:
            self._queued.pop(handler, None)
        started.set()
        handler()
