"""How a script's node waits for an answer (a service response, an action's result).

The node usually is not spinning (MTC's scripts never spin theirs), so the wait spins it until
the future is done; a node an executor already spins on another thread (rclcpp's background
executor, MoveItPy's, a task node's) is only waited on.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import rclpy
from rclpy.node import Node

from interfaces_py.msgs import MoveItErrorCode

__all__ = ["SERVER_TIMEOUT", "NodeWaiter", "spin_until_done"]

#: s to wait for move_group's parameters, services and action servers
SERVER_TIMEOUT = 10.0


#: s of one wait for the node's work while a future is not done (an answer ends it at once)
SPIN_PERIOD = 0.1


def spin_until_done(node: Node, future: Any, timeout: float) -> None:
    """Spin ``node`` (on rclpy's global executor, as rclpy.spin_until_future_complete does) until
    ``future`` is done or ``timeout`` s pass. One spin_once after another: each returns as soon as
    the answer's callback ran. rclpy's own spin_until_future_complete added 3-9 ms to every
    service call here (a bare std_srvs/Trigger round trip: 3.3-9.6 ms against 0.3 ms this way),
    as it waits again for a wake-up that the future's done callback only schedules."""
    executor = rclpy.get_global_executor()
    added = executor.add_node(node)
    try:
        deadline = time.monotonic() + timeout
        while not future.done() and node.context.ok():
            left = deadline - time.monotonic()
            if left <= 0.0:
                return
            executor.spin_once(timeout_sec=min(left, SPIN_PERIOD))
    finally:
        if added:
            executor.remove_node(node)


class NodeWaiter:
    """Waits for a node's futures, spinning the node only when no executor spins it already."""

    def __init__(self, node: Node) -> None:
        if not isinstance(node, Node):
            raise TypeError(f"expected an rclpy Node, got {type(node).__name__}")
        self.node = node
        self._spun_by: Any = None  # the executor our own spinning left the node in

    def wait(self, future: Any, timeout: float) -> Any:
        """The future's result once done (TimeoutError after ``timeout`` s, the future cancelled)."""
        executor = self.node.executor
        if executor is None or executor is self._spun_by:
            # (spinning leaves the node's executor set to the one it used)
            spin_until_done(self.node, future, timeout)
            self._spun_by = self.node.executor
        else:
            done = threading.Event()
            future.add_done_callback(lambda _f: done.set())
            done.wait(timeout)
        if not future.done():
            future.cancel()
            raise TimeoutError(f"no answer within {timeout:g} s")
        return future.result()

    def call(self, client: Any, request: Any, what: str, timeout: float) -> Any:
        """A service call's response; TimeoutError saying what was being done and which service."""
        started = time.monotonic()
        if not client.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f"{what}: no server answers on {client.srv_name} within {timeout:g} s "
                               "(is the planning_server running?)")
        try:
            return self.wait(client.call_async(request), max(0.1, timeout - (time.monotonic() - started)))
        except TimeoutError as exc:
            raise TimeoutError(f"{what}: {exc}") from None

    def run_goal(self, client: Any, goal: Any, result_timeout: float, server_timeout: float = SERVER_TIMEOUT,
                 source: str = "") -> tuple[Any, MoveItErrorCode | None]:
        """Send an action goal and wait for its result: ``(result, None)``, or ``(None, why)``
        when no server answers, the goal is refused or no result comes within ``result_timeout``
        (the goal is then cancelled)."""
        action = client._action_name.lstrip("/")
        if not client.wait_for_server(timeout_sec=server_timeout):
            return None, MoveItErrorCode(MoveItErrorCode.COMMUNICATION_FAILURE,
                                         f"no {action} action server answers within {server_timeout:g} s "
                                         "(is the planning_server running?)", source)
        try:
            handle = self.wait(client.send_goal_async(goal), server_timeout)
        except TimeoutError:
            handle = None
        if handle is None or not handle.accepted:
            return None, MoveItErrorCode(MoveItErrorCode.COMMUNICATION_FAILURE,
                                         f"the {action} goal was not accepted", source)
        try:
            return self.wait(handle.get_result_async(), result_timeout).result, None
        except TimeoutError:
            handle.cancel_goal_async()
            return None, MoveItErrorCode(MoveItErrorCode.TIMED_OUT,
                                         f"{action} gave no result within {result_timeout:.0f} s", source)
