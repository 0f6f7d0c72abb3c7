"""ROS requests a behavior waits on without blocking the tree: an action goal or a service call
whose completion wakes the tree up, and which a halt cancels (a canceled move_group or controller
goal stops the arm)."""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from action_msgs.msg import GoalStatus

#: how long a request waits for its server to be discovered before it fails
DISCOVERY_TIMEOUT = 10.0
#: PendingCall.answer_of's answer when the future failed
FAILED = object()


def _when_ready(is_ready: Callable[[], bool], wait: Callable[[float], bool], send: Callable[[], None],
                fail: Callable[[], None]) -> None:
    """``send()`` now if the server is known, else from a helper thread once it is discovered
    (``fail()`` if it is not within DISCOVERY_TIMEOUT): the tree never blocks on discovery."""
    if is_ready():
        send()
        return

    def wait_then_send() -> None:
        if wait(DISCOVERY_TIMEOUT):
            send()
        else:
            fail()

    threading.Thread(target=wait_then_send, name="wait for server", daemon=True).start()


class PendingCall:
    """One request in flight: ``done`` once answered (``result``) or failed (``error``)."""

    def __init__(self, wake: Callable[[], None]) -> None:
        self._wake = wake
        self._lock = threading.Lock()
        self.done = False
        self.result: Any = None
        self.status: int = GoalStatus.STATUS_UNKNOWN
        self.error: str | None = None

    def resolve(self, result: Any = None, error: str | None = None, status: int = GoalStatus.STATUS_UNKNOWN) -> None:
        """Complete the call (once; later completions are ignored) and wake the tree up."""
        with self._lock:
            if self.done:
                return
            self.done, self.result, self.error, self.status = True, result, error, status
        self._wake()

    def cancel(self) -> None:
        """Give up on the answer (services cannot be canceled)."""
        self.resolve(error="canceled")

    def answer_of(self, future: Any) -> Any:
        """The future's result; when it carries the transport's error instead, the call fails
        with that error and the answer is FAILED."""
        try:
            return future.result()
        except Exception as exc:
            self.resolve(error=f"{type(exc).__name__}: {exc}")
            return FAILED


class PendingService(PendingCall):
    def __init__(self, client: Any, request: Any, wake: Callable[[], None], name: str) -> None:
        super().__init__(wake)
        _when_ready(client.service_is_ready, lambda t: client.wait_for_service(timeout_sec=t),
                    lambda: client.call_async(request).add_done_callback(self._on_response),
                    lambda: self.resolve(error=f"service {name} is not available"))

    def _on_response(self, future: Any) -> None:
        response = self.answer_of(future)
        if response is not FAILED:
            self.resolve(response)


class PendingGoal(PendingCall):
    """An action goal; ``cancel`` cancels it on the server (and waits for nothing)."""

    def __init__(self, client: Any, goal: Any, wake: Callable[[], None], name: str) -> None:
        super().__init__(wake)
        self.name = name
        self._handle: Any = None
        self._cancel_requested = False
        _when_ready(client.server_is_ready, lambda t: client.wait_for_server(timeout_sec=t),
                    lambda: None if self.done else client.send_goal_async(goal).add_done_callback(self._on_accepted),
                    lambda: self.resolve(error=f"action server {name} is not available"))

    def _on_accepted(self, future: Any) -> None:
        handle = self.answer_of(future)
        if handle is FAILED:
            return
        if not handle.accepted:
            self.resolve(error=f"{self.name} rejected the goal")
            return
        with self._lock:
            self._handle = handle
            cancel = self._cancel_requested
        if cancel:
            handle.cancel_goal_async()
        handle.get_result_async().add_done_callback(self._on_result)

    def _on_result(self, future: Any) -> None:
        answer = self.answer_of(future)
        if answer is not FAILED:
            self.resolve(answer.result, status=answer.status)

    def cancel(self) -> None:
        with self._lock:
            self._cancel_requested = True
            handle = self._handle
        if handle is not None and not self.done:
            handle.cancel_goal_async()
        super().cancel()
