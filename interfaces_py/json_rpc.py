"""Request/response over two std_msgs/String topics: the replacement for custom ROS services.

The design card allows only standard messages and std_srvs services, and std_srvs requests carry
no data. So a node that answers requests with data (the planning server, perception) listens on
``<node>/requests`` and answers on ``<node>/responses``; each message is one JSON envelope:

    request:  {"id": "<uuid>", "method": "plan", "params": {...}}
    response: {"id": "<uuid>", "ok": true, "result": {...}}
              {"id": "<uuid>", "ok": false, "error": {"code": -31, "message": "..."}}

User code never sees this: JsonRpcClient.call() blocks until the answer with the same id arrives
or the timeout passes, and JsonRpcServer dispatches to plain Python handlers, turning any error
into an error response so that a bad request can never take the node down.
"""
from __future__ import annotations

import json
import threading
import time
import uuid
from typing import Any, Callable

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

#: Reliable, volatile, deep enough for bursts of scene updates.
RPC_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: Error codes outside MoveIt's range for protocol-level problems.
BAD_REQUEST = -1001
UNKNOWN_METHOD = -1002
INTERNAL_ERROR = -1003


class RpcError(Exception):
    """An error answer from the server (code, message) or a client-side timeout."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    def __str__(self) -> str:
        return self.message


class RpcTimeout(RpcError):
    def __init__(self, message: str) -> None:
        super().__init__(-6, message)  # MoveItErrorCode.TIMED_OUT


def topic_names(server: str) -> tuple[str, str]:
    """(requests, responses) topic names of a server node ("/planning_server")."""
    base = server if server.startswith("/") else f"/{server}"
    return f"{base}/requests", f"{base}/responses"


Handler = Callable[[dict[str, Any]], Any]


class JsonRpcServer:
    """Serves methods of a node; handlers take the params dict and return a JSON-able result.

    A handler signals a failure by raising RpcError(code, message) (or any exception, which is
    reported as INTERNAL_ERROR with its message). Handlers run on a reentrant callback group, so a
    long one (executing a trajectory) does not block the others (stop, get scene) when the node is
    spun by a MultiThreadedExecutor.
    """

    def __init__(self, node: Node, server_name: str | None = None) -> None:
        self._node = node
        requests, responses = topic_names(server_name or node.get_fully_qualified_name())
        self._handlers: dict[str, Handler] = {}
        self._publisher = node.create_publisher(String, responses, RPC_QOS)
        self._group = ReentrantCallbackGroup()
        self._subscription = node.create_subscription(
            String, requests, self._on_request, RPC_QOS, callback_group=self._group
        )

    def register(self, method: str, handler: Handler) -> None:
        self._handlers[method] = handler

    @property
    def methods(self) -> list[str]:
        return sorted(self._handlers)

    def _on_request(self, msg: String) -> None:
        request_id = None
        try:
            envelope = json.loads(msg.data)
            if not isinstance(envelope, dict):
                raise RpcError(BAD_REQUEST, "request must be a JSON object")
            request_id = envelope.get("id")
            method = envelope.get("method")
            params = envelope.get("params", {}) or {}
            if not isinstance(request_id, str) or not request_id:
                raise RpcError(BAD_REQUEST, "request lacks a string 'id'")
            if not isinstance(params, dict):
                raise RpcError(BAD_REQUEST, "'params' must be a JSON object")
            handler = self._handlers.get(method)
            if handler is None:
                raise RpcError(UNKNOWN_METHOD, f"unknown method '{method}'; known: {', '.join(self.methods)}")
            result = handler(params)
            reply = {"id": request_id, "ok": True, "result": result if result is not None else {}}
        except json.JSONDecodeError as exc:
            self._node.get_logger().warning(f"rejected a request that is not JSON: {exc}")
            reply = {"id": request_id, "ok": False, "error": {"code": BAD_REQUEST, "message": f"malformed JSON: {exc}"}}
        except RpcError as exc:
            self._node.get_logger().warning(f"request {request_id}: {exc.message}")
            reply = {"id": request_id, "ok": False, "error": {"code": exc.code, "message": exc.message}}
        except Exception as exc:  # a bad request must never take the node down: answer it instead
            self._node.get_logger().error(f"request {request_id} failed: {type(exc).__name__}: {exc}")
            reply = {
                "id": request_id,
                "ok": False,
                "error": {"code": INTERNAL_ERROR, "message": f"{type(exc).__name__}: {exc}"},
            }
        if request_id is not None:
            self._publisher.publish(String(data=json.dumps(reply)))


class JsonRpcClient:
    """Blocking calls to a JsonRpcServer. The node must be spun by an executor in another thread
    (the interfaces_py clients do that for you)."""

    def __init__(self, node: Node, server: str) -> None:
        self._node = node
        self.server = server
        requests, responses = topic_names(server)
        self._publisher = node.create_publisher(String, requests, RPC_QOS)
        self._pending: dict[str, dict[str, Any]] = {}
        self._events: dict[str, threading.Event] = {}
        self._lock = threading.Lock()
        self._subscription = node.create_subscription(
            String, responses, self._on_response, RPC_QOS, callback_group=ReentrantCallbackGroup()
        )

    def _on_response(self, msg: String) -> None:
        try:
            envelope = json.loads(msg.data)
        except json.JSONDecodeError:
            return
        request_id = envelope.get("id") if isinstance(envelope, dict) else None
        with self._lock:
            event = self._events.get(request_id)
            if event is not None:
                self._pending[request_id] = envelope
                event.set()

    def wait_for_server(self, timeout: float) -> bool:
        """True once the server's request subscription and response publisher are matched."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self._publisher.get_subscription_count() > 0 and self._subscription_matched():
                return True
            time.sleep(0.02)
        return False

    def _subscription_matched(self) -> bool:
        _, responses = topic_names(self.server)
        return self._node.count_publishers(responses) > 0

    def call(self, method: str, params: dict[str, Any] | None = None, timeout: float = 10.0) -> Any:
        """The result of `method`, or RpcError with the server's code and message (RpcTimeout if
        no answer arrives in time)."""
        started = time.monotonic()
        if not self.wait_for_server(timeout):
            raise RpcTimeout(f"no server '{self.server}' answering within {timeout:.1f} s (is it running?)")
        request_id = uuid.uuid4().hex
        event = threading.Event()
        with self._lock:
            self._events[request_id] = event
        try:
            self._publisher.publish(
                String(data=json.dumps({"id": request_id, "method": method, "params": params or {}}))
            )
            remaining = max(0.0, timeout - (time.monotonic() - started))
            if not event.wait(remaining):
                raise RpcTimeout(f"'{method}' on '{self.server}' got no answer within {timeout:.1f} s")
            with self._lock:
                envelope = self._pending.pop(request_id)
        finally:
            with self._lock:
                self._events.pop(request_id, None)
                self._pending.pop(request_id, None)
        if envelope.get("ok"):
            return envelope.get("result")
        error = envelope.get("error") or {}
        raise RpcError(int(error.get("code", INTERNAL_ERROR)), str(error.get("message", "unknown error")))
