"""py_binding_tools' ``rclcpp`` module, as MTC's ROS 2 Python scripts use it, on rclpy.

MTC's scripts start with ``rclcpp.init()`` and ``node = rclcpp.Node("mtc_tutorial")`` (or with
``NodeOptions`` and ``automatically_declare_parameters_from_overrides = True``) and hand that node
to ``task.loadRobotModel`` and ``PipelinePlanner``. As py_binding_tools does, :func:`init`
initializes ROS once (reference counted; a context already initialized by rclpy is reused, with
its warning), and every Node made here is spun by one executor on a background thread, so a
script never spins anything itself. The nodes are rclpy nodes: everything rclpy offers works on
them too. The spinning thread stops at :func:`shutdown` or when the interpreter exits.
"""
from __future__ import annotations

import sys
import threading
from typing import Any, Sequence

import rclpy
import rclpy.logging
import rclpy.node
from rclpy.executors import SingleThreadedExecutor

from interfaces_py.background_spin import BackgroundSpin

__all__ = ["Node", "NodeOptions", "init", "ok", "shutdown"]

_LOGGER = rclpy.logging.get_logger("InitProxy")


class NodeOptions:
    """rclcpp::NodeOptions' Python face (py_binding_tools): attributes, settable as keywords."""

    __slots__ = ("arguments", "use_global_arguments", "enable_rosout", "use_intra_process_comms",
                 "start_parameter_event_publisher", "use_clock_thread", "allow_undeclared_parameters",
                 "automatically_declare_parameters_from_overrides")

    def __init__(self, **kwargs: Any) -> None:
        self.arguments: list[str] = []
        self.use_global_arguments = True
        self.enable_rosout = True
        self.use_intra_process_comms = False  # rclpy has no intra-process transport: kept, not used
        self.start_parameter_event_publisher = True
        self.use_clock_thread = True  # rclpy has no clock thread: kept, not used
        self.allow_undeclared_parameters = False
        self.automatically_declare_parameters_from_overrides = False
        for key, value in kwargs.items():
            setattr(self, key, value)  # AttributeError for a name NodeOptions does not have

    def __repr__(self) -> str:
        return "NodeOptions(" + ", ".join(f"{k}={getattr(self, k)!r}" for k in self.__slots__) + ")"


class _InitProxy:
    """py_binding_tools' InitProxy: ROS initialized once, one executor spinning every Node."""

    def __init__(self, args: Sequence[str]) -> None:
        self.usage = 0
        self.initialized_here = False
        if rclpy.ok():
            _LOGGER.warning("rclcpp::init was already called by other means.")
        else:
            rclpy.init(args=list(args))
            self.initialized_here = True
        self.executor = SingleThreadedExecutor()
        self.spin = BackgroundSpin(self.executor, name="rclcpp executor")

    def add_node(self, node: rclpy.node.Node) -> None:
        self.executor.add_node(node)

    def close(self) -> None:
        self.spin.stop()
        if self.initialized_here:
            rclpy.try_shutdown()


_lock = threading.Lock()
_proxy: _InitProxy | None = None


def init(args: Sequence[str] | None = None) -> None:
    """Initialize ROS (``sys.argv`` when no args are given; --ros-args are read from them)."""
    global _proxy
    with _lock:
        if _proxy is None:
            _proxy = _InitProxy(sys.argv if args is None else [str(a) for a in args])
        _proxy.usage += 1


def shutdown() -> None:
    """Undo one init(); the last one stops the spinning and shuts ROS down."""
    global _proxy
    with _lock:
        if _proxy is None or _proxy.usage == 0:
            _LOGGER.error("Called rclcpp.shutdown() without a matching call to rclcpp.init()!")
            return
        _proxy.usage -= 1
        if _proxy.usage == 0:
            proxy, _proxy = _proxy, None
            proxy.close()


def ok() -> bool:
    return rclpy.ok()


class Node(rclpy.node.Node):
    """``rclcpp.Node(name, options=NodeOptions())``: an rclpy node, spun in the background."""

    def __init__(self, name: str, options: NodeOptions | None = None) -> None:
        options = NodeOptions() if options is None else options
        if not isinstance(options, NodeOptions):
            raise TypeError(f"options must be an rclcpp.NodeOptions, got {type(options).__name__}")
        super().__init__(
            name,
            cli_args=list(options.arguments) or None,
            use_global_arguments=bool(options.use_global_arguments),
            enable_rosout=bool(options.enable_rosout),
            start_parameter_services=True,
            allow_undeclared_parameters=bool(options.allow_undeclared_parameters),
            automatically_declare_parameters_from_overrides=bool(
                options.automatically_declare_parameters_from_overrides),
        )
        with _lock:
            if _proxy is not None:
                _proxy.add_node(self)

    @property
    def name(self) -> str:
        return self.get_name()
