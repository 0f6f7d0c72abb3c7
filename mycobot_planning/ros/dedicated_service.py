"""A ROS service answered on threads of its own, outside its node's executor.

Why: rclpy's multi-threaded executor rebuilds the node's whole wait set in Python three times per
request (move_group's: 44 entities, 200-250 µs each), competing with the handler: about 1 ms of
each move_group call. Here ``threads`` threads take turns (leader and followers): one waits in a
wait set of its own; the one that takes a request wakes a follower to wait instead, answers, then
takes the waiting back, so requests in turn stay on one warm thread and up to ``threads`` run at
once (all waiting together woke every thread per request: 0.25 ms a plan; docs/bench.md,
moveit_api). The node's executor (stop topic, cancels) never waits behind these requests. The
service is rclpy's own Service, on the ROS graph as any other.
"""
from __future__ import annotations

import threading
import traceback
from typing import Any, Callable

from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_services_default
from rclpy.service import Service
from rclpy.type_support import check_is_valid_srv_type

__all__ = ["DedicatedService", "after_response"]

#: s: how often an idle thread looks whether its context is still up (rclpy's shutdown does not
#: wake a wait set that holds none of the context's own guard conditions)
_POLL_S = 0.25


_HANDLING = threading.local()  # .pending: what runs once this thread's response is sent


def after_response(work: Callable[[], None]) -> bool:
    """Run ``work`` once the response of the request this thread is handling has been sent: for
    what the client does not wait for (a log line, waking a publisher thread), so it does not add to
    the call's time. False (``work`` not taken: run it yourself) outside a DedicatedService handler."""
    pending = getattr(_HANDLING, "pending", None)
    if pending is None:
        return False
    pending.append(work)
    return True


class DedicatedService:
    """``node``'s service ``name`` of type ``srv_type``, ``handler(request, response) -> response``
    called on one of ``threads`` threads of its own; ``close()`` stops them and destroys it."""

    def __init__(self, node: Node, srv_type: Any, name: str, handler: Callable[[Any, Any], Any],
                 threads: int = 2, qos_profile: QoSProfile = qos_profile_services_default) -> None:
        if threads < 1:
            raise ValueError(f"a DedicatedService needs at least one thread, got {threads}")
        self._node = node
        self._context = node.context
        self._handler = handler
        self._stopping = False
        check_is_valid_srv_type(srv_type)  # also loads the type support, as Node.create_service
        with node.handle:
            impl = _rclpy.Service(node.handle, srv_type, name, qos_profile.get_c_qos_profile())
        # rclpy's Service for its response sending and destruction; never added to the node, so
        # no executor waits on it
        self._service = Service(impl, srv_type, name, handler, None, qos_profile)
        self._wake = GuardCondition(None, None, context=self._context)  # stop
        self._yield = GuardCondition(None, None, context=self._context)  # give the lead back
        self._turns = threading.Lock()  # guards the three below
        self._leading = False  # a thread waits for the next request
        self._followers: list[threading.Event] = []  # idle threads, the latest idle last
        self._reclaimer: threading.Event | None = None  # a thread that answered and waits again
        self._threads = [threading.Thread(target=self._serve, name=f"service {name}", daemon=True)
                         for _ in range(threads)]
        for thread in self._threads:
            thread.start()

    @property
    def srv_name(self) -> str:
        return self._service.srv_name

    def close(self, timeout: float = 2.0) -> None:
        """Stop the threads (a request being handled is finished first, up to ``timeout`` s),
        then destroy the service."""
        self._stopping = True
        try:
            self._wake.trigger()
        except Exception:  # the context is gone already: the threads see it on their next poll
            pass
        with self._turns:
            for turn in [*self._followers, self._reclaimer]:
                if turn is not None:
                    turn.set()
        for thread in self._threads:
            if thread is not threading.current_thread():
                thread.join(timeout)
        self._service.destroy()
        self._wake.destroy()
        self._yield.destroy()

    def _serve(self) -> None:
        turn = threading.Event()  # set when this thread is to lead (or to stop)
        leading = False
        try:
            with self._context.handle:
                wait_set = _rclpy.WaitSet(0, 2, 0, 0, 1, 0, self._context.handle)
            answered = False
            while self._lead(turn, answered):
                leading = True
                taken = self._take(wait_set, turn)
                leading = False
                self._hand_over()
                answered = taken is not None
                if answered:
                    self._answer(*taken)
        except Exception as exc:  # a handle destroyed or the context shut down under a wait
            if leading:
                self._hand_over()
            if self._running():
                self._node.get_logger().error(f"{self.srv_name}: stopped answering: {type(exc).__name__}: {exc}")

    def _running(self) -> bool:
        return not self._stopping and self._context.ok()

    def _lead(self, turn: threading.Event, answered: bool) -> bool:
        """Become a thread that waits for requests: at once if none does, or if this thread has
        just ``answered`` (the waiting leader then steps down when it sees it); else wait for a
        turn. False when the service stops (the lead then passes on, so every thread ends soon)."""
        with self._turns:
            if not self._leading:
                self._leading = True
                turn.set()
            elif answered and self._reclaimer is None:
                self._reclaimer = turn
                turn.set()
            else:
                turn.clear()
                self._followers.append(turn)
        if self._reclaimer is turn:
            self._yield.trigger()
        while not turn.wait(_POLL_S):
            if not self._running():
                with self._turns:
                    if turn in self._followers:
                        self._followers.remove(turn)
                        return False
        if self._running():
            return True
        self._hand_over()
        return False

    def _hand_over(self) -> None:
        """Leave the waiting to another thread: to the one that took it back already if there is
        one, else to the follower idle the shortest time."""
        with self._turns:
            if self._reclaimer is not None:
                self._reclaimer = None  # it waits already: the only leader from now on
            elif self._followers:
                self._followers.pop().set()
            else:
                self._leading = False

    def _take(self, wait_set: Any, turn: threading.Event) -> tuple[Any, Any] | None:
        """Wait for a request and take it; None when the service stops or another thread that
        answered has taken the waiting back."""
        while self._running() and self._reclaimer in (None, turn):
            with self._service.handle, self._wake.handle, self._yield.handle:
                wait_set.clear_entities()
                wait_set.add_service(self._service.handle)
                wait_set.add_guard_condition(self._wake.handle)
                wait_set.add_guard_condition(self._yield.handle)
                wait_set.wait(int(_POLL_S * 1e9))
                if self._stopping or not wait_set.get_ready_entities("service"):
                    continue
                taken = self._service.handle.service_take_request(self._service.srv_type.Request)
            if taken is not None and taken[1] is not None:
                return taken
        return None

    def _answer(self, request: Any, header: Any) -> None:
        _HANDLING.pending = pending = []
        try:
            self._respond(request, header)
        finally:
            _HANDLING.pending = None
            for work in pending:
                try:
                    work()
                except Exception as exc:
                    self._node.get_logger().error(f"{self.srv_name}: after the response: {type(exc).__name__}: {exc}")

    def _respond(self, request: Any, header: Any) -> None:
        try:
            response = self._handler(request, self._service.srv_type.Response())
        except Exception as exc:  # handlers answer their own failures; this is the last guard
            self._node.get_logger().error(f"{self.srv_name} failed: {type(exc).__name__}: {exc}\n"
                                          f"{traceback.format_exc()}")
            response = self._service.srv_type.Response()
        try:
            self._service.send_response(response, header)
        except Exception as exc:
            if self._context.ok() and not self._stopping:
                self._node.get_logger().error(f"{self.srv_name}: the response could not be sent: "
                                              f"{type(exc).__name__}: {exc}")
