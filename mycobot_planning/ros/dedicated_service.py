"""A ROS service answered on threads of its own, outside its node's executor.

Why: rclpy's multi-threaded executor rebuilds the node's whole wait set in Python three times
per request (move_group's: 44 entities, 200-250 µs each time), and those rebuilds compete with
the handler for the interpreter: about 1 ms of each move_group call (docs/bench.md, moveit_api).
A DedicatedService waits in a wait set of its own (the service and a guard condition that stops
it) on ``threads`` threads; the thread that takes a request runs the handler and sends the
response, so up to ``threads`` requests of the service run at once. The rest of the node (its
stop topic, its actions' cancels) stays on the executor and never waits behind these requests.
The service is created through rclpy's own Service class, so it is on the ROS graph as any
other (``ros2 service list``, clients' ``wait_for_service``).
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

__all__ = ["DedicatedService"]

#: s: how often an idle thread looks whether its context is still up (rclpy's shutdown does not
#: wake a wait set that holds none of the context's own guard conditions)
_POLL_S = 0.25


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
        self._wake = GuardCondition(None, None, context=self._context)
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
        for thread in self._threads:
            if thread is not threading.current_thread():
                thread.join(timeout)
        self._service.destroy()
        self._wake.destroy()

    def _serve(self) -> None:
        try:
            with self._context.handle:
                wait_set = _rclpy.WaitSet(0, 1, 0, 0, 1, 0, self._context.handle)
            while not self._stopping and self._context.ok():
                with self._service.handle, self._wake.handle:
                    wait_set.clear_entities()
                    wait_set.add_service(self._service.handle)
                    wait_set.add_guard_condition(self._wake.handle)
                    wait_set.wait(int(_POLL_S * 1e9))
                    if self._stopping or not wait_set.get_ready_entities("service"):
                        continue
                    taken = self._service.handle.service_take_request(self._service.srv_type.Request)
                if taken is None or taken[1] is None:  # another thread took it first
                    continue
                self._answer(*taken)
        except Exception as exc:  # a handle destroyed or the context shut down under a wait
            if self._context.ok() and not self._stopping:
                self._node.get_logger().error(f"{self.srv_name}: stopped answering: {type(exc).__name__}: {exc}")

    def _answer(self, request: Any, header: Any) -> None:
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
