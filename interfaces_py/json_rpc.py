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
import re
import threading
import time
import traceback
import uuid
from typing import Any, Callable

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from interfaces_py.msgs import printable

#: Reliable, volatile, deep enough for bursts of scene updates.
RPC_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: Error codes outside MoveIt's range for protocol-level problems.
BAD_REQUEST = -1001
UNKNOWN_METHOD = -1002
INTERNAL_ERROR = -1003

#: Largest request a server decodes (bytes of JSON text). The biggest legitimate requests are
#: scene batches and meshes: 1,000 boxes are about 0.4 MB, the perception pipeline's meshes a few
#: hundred kB; 16 MiB leaves room for large meshes and refuses a flood before json.loads holds it
#: twice in memory.
MAX_REQUEST_BYTES = 16 * 1024 * 1024
#: Deepest nesting of JSON arrays/objects a request may have. Our deepest message (a task
#: solution: solution -> sub_trajectory -> trajectory -> points -> positions) is about 10 levels;
#: a hostile 5,000-level request would otherwise exhaust the recursion of json.loads and of the
#: message classes.
MAX_REQUEST_DEPTH = 64

_ID_PATTERN = re.compile(r'"id"\s*:\s*"([0-9A-Za-z_-]{1,64})"')


def log_safe(text: Any, limit: int = 2000) -> str:
    """``text`` as a log line can always take it: lone surrogates (which JSON can carry but
    UTF-8 cannot, and which make rclpy's logging raise) and control characters other than newline
    and tab are escaped, and long texts are cut."""
    return printable(str(text), limit, keep="\n\t")


def _depth_problem(value: Any, limit: int, check_strings: bool) -> str | None:
    """Why ``value`` (decoded JSON) is unacceptable as text or shape, or None.

    Strings that UTF-8 cannot encode (lone surrogates from ``"\\ud800"`` escapes) are refused here,
    once, at the boundary: every later log line and message may then echo request strings.
    """
    stack = [(value, 1, "request")]
    while stack:
        item, depth, path = stack.pop()
        if depth > limit:
            return f"{path} is nested more than {limit} levels deep"
        pairs = item.items() if isinstance(item, dict) else enumerate(item)
        for key, v in pairs:
            if isinstance(v, (dict, list)):
                stack.append((v, depth + 1, f"{path}.{key}" if isinstance(key, str) else f"{path}[{key}]"))
            elif check_strings:
                for text in (key, v):
                    if isinstance(text, str) and not _encodable(text):
                        where = f"{path}.{log_safe(key, 40)}" if isinstance(key, str) else f"{path}[{key}]"
                        return f"{where} is not valid Unicode (a lone surrogate): {log_safe(text, 80)}"
    return None


def _max_depth(value: Any) -> int:
    """Nesting depth of decoded JSON (1 for a flat object), without building paths."""
    deepest = 0
    stack = [(value, 1)] if isinstance(value, (dict, list)) else []
    while stack:
        item, depth = stack.pop()
        deepest = max(deepest, depth)
        for v in (item.values() if isinstance(item, dict) else item):
            if isinstance(v, (dict, list)):
                stack.append((v, depth + 1))
    return deepest


def _encodable(text: str) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def decode_request(text: str, what: str = "request") -> Any:
    """JSON text from the wire, checked once at the boundary: size, nesting, Unicode.

    Raises RpcError(BAD_REQUEST) with a sentence; the decoded value is safe to echo in logs and
    answers afterwards.
    """
    if len(text) > MAX_REQUEST_BYTES:
        raise RpcError(BAD_REQUEST, f"{what} is {len(text)} bytes; the limit is {MAX_REQUEST_BYTES} bytes")
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise RpcError(BAD_REQUEST, f"malformed JSON: {exc}") from None
    except RecursionError:
        raise RpcError(BAD_REQUEST, f"{what} is nested more than {MAX_REQUEST_DEPTH} levels deep") from None
    # JSON text from ROS is valid UTF-8, so a lone surrogate can only come from a \\uD800-\\uDFFF
    # escape: without one, no string needs checking.
    suspicious = "\\ud" in text or "\\uD" in text
    problem = None
    if suspicious or _max_depth(value) > MAX_REQUEST_DEPTH:  # the walk with paths only when it finds something
        problem = _depth_problem(value, MAX_REQUEST_DEPTH, suspicious) if isinstance(value, (dict, list)) else None
    if problem is not None:
        raise RpcError(BAD_REQUEST, problem)
    return value


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
        """Answer one request; nothing in it can raise out of here (a bad request gets an error
        answer, a handler bug gets INTERNAL_ERROR with a sentence, its traceback goes to the log)."""
        request_id = None
        try:
            try:
                envelope = decode_request(msg.data)
            except RpcError:
                match = _ID_PATTERN.search(msg.data[:4096])  # answer the caller even so
                request_id = match.group(1) if match else None
                raise
            if not isinstance(envelope, dict):
                raise RpcError(BAD_REQUEST, "request must be a JSON object")
            request_id = envelope.get("id")
            if not isinstance(request_id, str) or not request_id:
                request_id = None
                raise RpcError(BAD_REQUEST, "request lacks a string 'id'")
            method = envelope.get("method")
            params = envelope.get("params", {}) or {}
            unknown = sorted(str(k) for k in envelope if k not in ("id", "method", "params"))
            if unknown:
                raise RpcError(BAD_REQUEST, f"request has unknown keys {unknown}; known: id, method, params")
            if not isinstance(params, dict):
                raise RpcError(BAD_REQUEST, "'params' must be a JSON object")
            handler = self._handlers.get(method) if isinstance(method, str) else None
            if handler is None:
                raise RpcError(UNKNOWN_METHOD, f"unknown method {log_safe(repr(method), 80)}; known: {', '.join(self.methods)}")
            result = handler(params)
            reply = {"id": request_id, "ok": True, "result": result if result is not None else {}}
        except RpcError as exc:
            self._warn(f"request {request_id}: {exc.message}" if request_id else f"rejected a request: {exc.message}")
            reply = {"id": request_id, "ok": False, "error": {"code": exc.code, "message": log_safe(exc.message)}}
        except RecursionError:
            self._warn(f"request {request_id}: nested too deeply")
            reply = {"id": request_id, "ok": False, "error": {
                "code": BAD_REQUEST, "message": f"request is nested more than {MAX_REQUEST_DEPTH} levels deep"}}
        except Exception as exc:  # a bad request must never take the node down: answer it instead
            self._error(f"request {request_id} failed inside the server: {type(exc).__name__}: {exc}\n"
                        + traceback.format_exc())
            reply = {"id": request_id, "ok": False, "error": {
                "code": INTERNAL_ERROR,
                "message": "the server could not process this request (an internal error; its log has the details)"}}
        if request_id is not None:
            try:
                self._publisher.publish(String(data=json.dumps(reply)))
            except Exception as exc:  # e.g. a result that is not JSON-able: still answer
                self._error(f"request {request_id}: the answer could not be sent: {type(exc).__name__}: {exc}")
                self._publisher.publish(String(data=json.dumps({"id": request_id, "ok": False, "error": {
                    "code": INTERNAL_ERROR, "message": "the server could not encode its answer (see its log)"}})))

    def _warn(self, text: str) -> None:
        self._node.get_logger().warning(log_safe(text))

    def _error(self, text: str) -> None:
        self._node.get_logger().error(log_safe(text, limit=8000))


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
