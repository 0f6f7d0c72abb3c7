"""What every node of the package shares: start-up and shutdown, and declared, validated parameters.

ROS users expect `ros2 param describe` to explain a parameter, `ros2 param set` to refuse a bad
value with a reason (never to crash the node or half-apply), and Ctrl-C / SIGTERM to stop a node
cleanly. Each node declares its parameters through `ParameterSpec`s and starts through
`run_node`, so all nodes behave the same way.
"""
from __future__ import annotations

import math
import signal
import sys
import threading
import time
from pathlib import Path
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import rclpy
import yaml
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.exceptions import ParameterException, ParameterUninitializedException
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from mycobot_planning.paths import use_fast_discovery
from mycobot_planning.ros.executors import MultiThreadedExecutor


Validator = Callable[[Any], str | None]  # returns an error sentence, or None when the value is fine


@dataclass(frozen=True)
class ParameterSpec:
    """One declared parameter: default, human description, optional range/size/check."""

    name: str
    default: Any
    description: str
    range: tuple[float, float] | None = None  # inclusive
    array_size: int | None = None  # fixed length for arrays
    non_empty: bool = False  # strings (and string arrays' items) must not be empty
    read_only: bool = False
    validator: Validator | None = None
    dynamic_typing: bool = False
    #: the type of an array parameter whose default is empty (rclpy would infer "byte array")
    array_type: Parameter.Type = Parameter.Type.DOUBLE_ARRAY

    def descriptor(self) -> ParameterDescriptor:
        extra = []
        if self.array_size is not None:
            extra.append(f"exactly {self.array_size} values")
        if self.non_empty:
            extra.append("must not be empty")
        descriptor = ParameterDescriptor(
            description=self.description + (f" ({'; '.join(extra)})" if extra else ""),
            read_only=self.read_only,
            dynamic_typing=self.dynamic_typing,
        )
        if self.range is not None:
            low, high = self.range
            if isinstance(self.default, bool):
                pass
            elif isinstance(self.default, int):
                descriptor.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=0)]
            elif isinstance(self.default, float):
                descriptor.floating_point_range = [FloatingPointRange(from_value=float(low), to_value=float(high), step=0.0)]
        return descriptor

    def check(self, value: Any) -> str | None:
        """Why `value` is not acceptable, or None."""
        if isinstance(value, float) and not math.isfinite(value):
            return f"{self.name} must be a finite number, got {value}"
        if isinstance(value, (list, tuple)):
            if self.array_size is not None and len(value) != self.array_size:
                return f"{self.name} must have exactly {self.array_size} values, got {len(value)}"
            if any(isinstance(v, float) and not math.isfinite(v) for v in value):
                return f"{self.name} must contain finite numbers only"
            if self.non_empty and (len(value) == 0 or any(isinstance(v, str) and not v.strip() for v in value)):
                return f"{self.name} must not be empty or contain empty names"
        if isinstance(value, str) and self.non_empty and not value.strip():
            return f"{self.name} must not be empty"
        if self.range is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
            low, high = self.range
            if not low <= value <= high:
                return f"{self.name} must be within [{low}, {high}], got {value}"
        if self.validator is not None:
            return self.validator(value)
        return None


class Parameters:
    """Declares specs on a node, validates every set against them, and notifies listeners."""

    def __init__(self, node: Node, specs: Sequence[ParameterSpec]) -> None:
        self._node = node
        self._specs = {spec.name: spec for spec in specs}
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        for spec in specs:
            try:
                if isinstance(spec.default, list) and not spec.default:
                    self._declare_empty_array(spec)
                else:
                    node.declare_parameter(spec.name, spec.default, spec.descriptor())
            except ParameterException as exc:  # e.g. a --ros-args value outside the declared range
                raise ValueError(f"parameter {spec.name}: {exc}") from None
        problems = [p for p in (spec.check(self.get(spec.name)) for spec in specs) if p]
        if problems:
            raise ValueError("invalid parameters: " + "; ".join(problems))
        node.add_on_set_parameters_callback(self._on_set)
        node.add_post_set_parameters_callback(self._after_set)

    def _declare_empty_array(self, spec: ParameterSpec) -> None:
        """An array parameter with an empty default, declared with its real type (rclpy reads an
        empty list as a byte array): statically typed ones are declared by type (taking a
        --ros-args override if given), then set to the typed empty array; dynamically typed ones
        are declared, then set to the typed empty array unless an override gave a value."""
        if spec.dynamic_typing:
            self._node.declare_parameter(spec.name, spec.default, spec.descriptor())
            if self._node.get_parameter(spec.name).type_ != Parameter.Type.BYTE_ARRAY \
                    or len(self._node.get_parameter(spec.name).value):
                return
        else:
            self._node.declare_parameter(spec.name, spec.array_type, spec.descriptor())
            try:
                self._node.get_parameter(spec.name)
                return
            except ParameterUninitializedException:
                pass
        result = self._node.set_parameters([Parameter(spec.name, spec.array_type, [])])[0]
        if not result.successful:
            raise ValueError(f"parameter {spec.name}: {result.reason}") from None

    def get(self, name: str) -> Any:
        value = self._node.get_parameter(name).value
        return list(value) if isinstance(value, (list, tuple)) or hasattr(value, "tolist") else value

    def values(self) -> dict[str, Any]:
        return {name: self.get(name) for name in self._specs}

    def on_change(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Call `listener({name: value})` after a set has been accepted."""
        self._listeners.append(listener)

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        for param in params:
            spec = self._specs.get(param.name)
            if spec is None:
                continue
            value = param.value
            if hasattr(value, "tolist"):
                value = value.tolist()
            reason = spec.check(value)
            if reason:
                self._node.get_logger().warning(f"refused {param.name}: {reason}")
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _after_set(self, params: list[Parameter]) -> None:
        changed = {p.name: self.get(p.name) for p in params if p.name in self._specs}
        if changed:
            for listener in self._listeners:
                try:
                    listener(changed)
                except Exception as exc:  # a listener's failure is logged, the node keeps running
                    self._node.get_logger().error(f"applying {sorted(changed)} failed: {exc}")


def load_yaml_file(path: str, what: str) -> dict | None:
    """A YAML mapping file named by a parameter (None for an empty name); ValueError names it."""
    if not path:
        return None
    try:
        data = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f"cannot read {what} '{path}': {exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what} '{path}' must hold a mapping")
    return data


#: s a node may take, after SIGINT/SIGTERM, to end what it is doing and answer its clients
#: (begin_shutdown, then while busy()) before rclpy is shut down
WIND_DOWN_TIMEOUT = 1.5
#: s given to the executor after that, for the last results and responses to go out
FLUSH_TIME = 0.1


def run_node(factory: Callable[[], Node], args: list[str] | None = None, threads: int = 4) -> int:
    """rclpy.init, build the node, spin it on a multi-threaded executor until Ctrl-C or SIGTERM,
    then tear down. A node that cannot start logs why and exits 1 instead of a traceback; a
    callback that raises is logged and the node goes on serving (one bad message must never take
    a node down).

    Shutdown answers clients: rclpy's own signal handlers would shut the context down at once
    (a running goal could then neither finish nor answer, and its abort() raised an RCLError
    traceback). Here SIGINT and SIGTERM only set a flag; the executor spins on a thread of its
    own while the main thread waits for that flag, then the node's optional ``begin_shutdown()``
    (the planning_server: stop plans and executions) runs and the node gets up to
    WIND_DOWN_TIMEOUT s while its optional ``busy()`` is true, with the executor still
    delivering results, before rclpy is shut down, ``close()`` called and the node destroyed."""
    use_fast_discovery()
    rclpy.init(args=args if args is not None else sys.argv, signal_handler_options=SignalHandlerOptions.NO)
    stop_requested = threading.Event()

    def on_signal(signum: int, frame: Any) -> None:
        stop_requested.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    node = None
    code = 0
    try:
        try:
            node = factory()
        except ValueError as exc:  # bad configuration: say what, do not print a traceback
            print(f"[ERROR] {exc}", file=sys.stderr)
            return 1
        # Each node of the process (planning_server: move_group too) spins on an executor of its
        # own: rclpy's executors walk every entity of their wait set on each wake-up (~20 us
        # each), so a request to one node does not pay for the other's entities (issue 26).
        failure: list[BaseException] = []
        spinners = []
        for index, each in enumerate([node, *getattr(node, "extra_nodes", ())]):
            # one thread: the single-threaded executor (rclpy's multi-threaded one re-polls queued
            # entities and warns when given one thread)
            executor = SingleThreadedExecutor() if threads <= 1 else MultiThreadedExecutor(num_threads=threads)
            executor.add_node(each)
            spinners.append(threading.Thread(target=_spin_thread, args=(each, executor, failure),
                                             name="executor" if index == 0 else f"executor {each.get_name()}",
                                             daemon=True))
        for spinner in spinners:
            spinner.start()
        while not stop_requested.wait(1.0):  # interruptible: the signal handler runs here
            if not all(spinner.is_alive() for spinner in spinners):
                break
        if stop_requested.is_set() and all(spinner.is_alive() for spinner in spinners):
            _wind_down(node)
        rclpy.try_shutdown()
        for spinner in spinners:
            spinner.join(2.0)
        if failure:
            raise failure[0]
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            close = getattr(node, "close", None)
            if callable(close):
                close()
            node.destroy_node()
        rclpy.try_shutdown()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return code


def _wind_down(node: Node) -> None:
    """After SIGINT/SIGTERM, rclpy still up: let the node end its work and answer its clients."""
    begin = getattr(node, "begin_shutdown", None)
    if callable(begin):
        try:
            begin()
        except Exception as exc:  # never let a shutdown step hide the shutdown
            node.get_logger().error(f"begin_shutdown failed: {type(exc).__name__}: {exc}")
    busy = getattr(node, "busy", None)
    deadline = time.monotonic() + WIND_DOWN_TIMEOUT
    while callable(busy) and time.monotonic() < deadline:
        try:
            if not busy():
                break
        except Exception:
            break
        time.sleep(0.02)
    time.sleep(FLUSH_TIME)


def _spin_thread(node: Node, executor: Executor, failure: list[BaseException]) -> None:
    try:
        _spin_guarded(node, executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as exc:
        # the context can go away while the executor waits; that is a shutdown, not an error
        if rclpy.ok():
            failure.append(exc)


def _spin_guarded(node: Node, executor: Executor) -> None:
    """executor.spin(), resumed after a callback raised: the executor re-raises a callback's
    exception out of spin(), which would end the process."""
    while rclpy.ok():
        try:
            executor.spin()
            return
        except (KeyboardInterrupt, ExternalShutdownException):
            raise
        except Exception as exc:
            if not rclpy.ok():
                return
            text = f"a callback raised {type(exc).__name__}: {exc}; the node goes on\n{traceback.format_exc()}"
            node.get_logger().error(text.encode("utf-8", "backslashreplace").decode("utf-8"))
