"""An rclpy executor spun on a thread of its own, stopped cleanly.

Why not ``Thread(target=executor.spin)`` with ``executor.shutdown()`` to stop it: in rclpy
(Jazzy), ``Executor.shutdown`` does not wait for the spinning thread (its wait is skipped once the
shutdown flag is set) and destroys the executor's guard conditions while that thread may still be
building a wait set. A test session was seen hanging in teardown with such a thread at 100 % of a
core while the main thread, starved of the GIL, could not finish a 5 s ``Popen.wait``. Here the
thread calls ``spin_once`` with a short timeout and checks a flag of its own between calls, so
``stop()`` ends it in at most about one timeout, and only then is the executor shut down.

Every BackgroundSpin still running when the interpreter exits is stopped by an ``atexit`` hook.
A daemon thread still inside ``spin_once`` while Python finalizes aborts the process
("terminate called without an active exception", exit code 134) or crashes it (139): a script
that drops a client without ``close()``, as every moveit_commander script does, must still exit
0. ``atexit`` hooks run after the main thread's last line and before finalization, while the
thread and its context still exist.
"""
from __future__ import annotations

import atexit
import threading
import weakref
from typing import Any

from rclpy.executors import ExternalShutdownException

__all__ = ["BackgroundSpin", "stop_all"]

#: s: the longest one spin_once call waits for work before the stop flag is looked at again
SPIN_PERIOD = 0.05


class BackgroundSpin:
    """Spin ``executor`` on a daemon thread named ``name`` until :meth:`stop` (or until its
    context is shut down). A callback that raises ends the thread, as ``executor.spin()`` would."""

    def __init__(self, executor: Any, name: str = "executor") -> None:
        self.executor = executor
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        _RUNNING.add(self)
        self.thread.start()

    def _run(self) -> None:
        context = self.executor.context
        try:
            while not self._stop.is_set() and context.ok():
                self.executor.spin_once(timeout_sec=SPIN_PERIOD)
        except (ExternalShutdownException, KeyboardInterrupt):
            pass  # the context was shut down under us: nothing left to spin
        except Exception:
            if context.ok() and not self._stop.is_set():
                raise  # a callback's own error, reported as executor.spin() would
            # else the context or the executor went away under us at exit: nothing left to spin

    def stop(self, timeout: float = 5.0) -> bool:
        """End the thread (waiting up to ``timeout`` for a running callback to return), then
        shut the executor down. True when the thread has ended."""
        self._stop.set()
        _RUNNING.discard(self)
        if self.thread is not threading.current_thread():
            self.thread.join(timeout)
        ended = not self.thread.is_alive()
        try:
            self.executor.shutdown(timeout_sec=1.0 if ended else 0.0)
        except Exception:  # noqa: BLE001 - best-effort teardown: the context may be gone already
            pass
        return ended


#: the spins not stopped yet (weakly: a BackgroundSpin nobody holds still runs, its thread holds it)
_RUNNING: "weakref.WeakSet[BackgroundSpin]" = weakref.WeakSet()


def stop_all(timeout: float = 5.0) -> None:
    """Stop every BackgroundSpin still running (what the interpreter does at exit)."""
    for spin in list(_RUNNING):
        spin.stop(timeout)


atexit.register(stop_all)
