"""Action nodes (BT.CPP's action_node.h): the bases a behavior is written on.

- ``SyncActionNode``: ``tick()`` answers SUCCESS or FAILURE at once (never RUNNING).
- ``StatefulActionNode``: ``on_start()`` / ``on_running()`` / ``on_halted()``; the way to wait
  for something asynchronous (a plan, an execution, a ROS action) without a thread: start it in
  ``on_start``, poll it in ``on_running``, cancel it in ``on_halted``. Call
  ``emit_wake_up_signal()`` from a completion callback so the tree ticks again at once.
- ``ThreadedAction``: ``tick()`` runs in its own thread; the tree sees RUNNING until it returns.
  ``tick`` must poll ``is_halt_requested()`` and return soon after a halt, because ``halt``
  waits for the thread (as in BT.CPP).
- ``SimpleActionNode``: a function ``f(node) -> NodeStatus`` as a node.
"""
from __future__ import annotations

import threading
from collections.abc import Callable

from .basic_types import FAILURE, IDLE, RUNNING, SUCCESS, NodeStatus, NodeType
from .exceptions import BehaviorTreeRuntimeError, LogicError
from .tree_node import NodeConfig, TreeNode


def as_status(result: NodeStatus | bool, who: str) -> NodeStatus:
    """A tick function's answer; True/False stand for SUCCESS/FAILURE."""
    if isinstance(result, NodeStatus):
        return result
    if isinstance(result, bool):
        return SUCCESS if result else FAILURE
    raise LogicError(f"{who} must return a NodeStatus (or a bool), got {result!r}")


class TickFunctorNode(TreeNode):
    """A node whose tick asks a function of the node, ``f(node) -> NodeStatus`` (or bool): the
    base of SimpleActionNode and SimpleConditionNode; ``KIND`` names the node in errors."""

    KIND = "node"

    def __init__(self, name: str, config: NodeConfig, tick_functor: Callable[[TreeNode], NodeStatus | bool]):
        super().__init__(name, config)
        self._tick_functor = tick_functor

    def functor_status(self) -> NodeStatus:
        return as_status(self._tick_functor(self), f"{self.KIND} [{self.name}]")


class ActionNodeBase(TreeNode):
    """A leaf that does something (BT.CPP's ActionNodeBase)."""

    NODE_TYPE = NodeType.ACTION


class SyncActionNode(ActionNodeBase):
    """An action that completes within its tick."""

    def execute_tick(self) -> NodeStatus:
        status = TreeNode.execute_tick(self)
        if status is RUNNING:
            raise LogicError(f"SyncActionNode [{self.name}] MUST never return RUNNING")
        return status

    def halt(self) -> None:
        self.reset_status()


class SimpleActionNode(TickFunctorNode, SyncActionNode):
    """A function as an action: ``f(node) -> NodeStatus`` (or bool)."""

    KIND = "action"

    def tick(self) -> NodeStatus:
        if self._status is IDLE:
            self.set_status(RUNNING)
        return self.functor_status()


class StatefulActionNode(ActionNodeBase):
    """An asynchronous action without a thread: ``on_start``, then ``on_running`` on every
    following tick while RUNNING, ``on_halted`` if it is interrupted."""

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._halt_requested = False

    def on_start(self) -> NodeStatus:  # pragma: no cover - abstract
        raise NotImplementedError

    def on_running(self) -> NodeStatus:  # pragma: no cover - abstract
        raise NotImplementedError

    def on_halted(self) -> None:
        """Stop whatever on_start started (cancel the goal, stop the motion)."""

    def is_halt_requested(self) -> bool:
        return self._halt_requested

    def tick(self) -> NodeStatus:
        previous = self._status
        if previous is IDLE:
            self._halt_requested = False
            status = self.on_start()
            if status is IDLE:
                raise LogicError(f"StatefulActionNode [{self.name}]: on_start() must not return IDLE")
            return as_status(status, f"[{self.name}].on_start()")
        if previous is RUNNING:
            status = self.on_running()
            if status is IDLE:
                raise LogicError(f"StatefulActionNode [{self.name}]: on_running() must not return IDLE")
            return as_status(status, f"[{self.name}].on_running()")
        return previous

    def halt(self) -> None:
        self._halt_requested = True
        if self._status is RUNNING:
            self.on_halted()
        self.reset_status()


class ThreadedAction(ActionNodeBase):
    """An action whose ``tick()`` runs in a thread of its own (BT.CPP's ThreadedAction).

    The first tick starts the thread and answers RUNNING; the thread's result becomes the
    node's status when it returns (and the tree is woken up). An exception in the thread is
    raised in the tree's thread at the next tick, naming the node.
    """

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._halt_event = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self._lock = threading.Lock()
        self.tick_in_thread = self.tick
        self.tick = self._threaded_tick  # type: ignore[method-assign]

    def is_halt_requested(self) -> bool:
        return self._halt_event.is_set()

    def _threaded_tick(self) -> NodeStatus:
        if self._status is IDLE:
            self.set_status(RUNNING)
            self._halt_event.clear()
            self._error = None
            self._thread = threading.Thread(target=self._run, name=f"bt:{self.config.path or self.name}",
                                            daemon=True)
            self._thread.start()
        with self._lock:
            error, self._error = self._error, None
        if error is not None:
            if isinstance(error, BehaviorTreeRuntimeError):
                raise error
            raise BehaviorTreeRuntimeError(f"{type(error).__name__} in the thread of tick(): {error}",
                                           self.config.path) from error
        return self._status

    def _run(self) -> None:
        try:
            status = as_status(self.tick_in_thread(), f"[{self.name}].tick()")
            if status is RUNNING or status is IDLE:
                raise LogicError(f"ThreadedAction [{self.name}].tick() must return SUCCESS or FAILURE, "
                                 f"not {status.name}")
            if not self._halt_event.is_set():
                self.set_status(status)
        except BaseException as exc:  # handed to the tree's thread
            with self._lock:
                self._error = exc
                if not self._halt_event.is_set():
                    self.set_status(FAILURE)
        finally:
            self.emit_wake_up_signal()

    def halt(self) -> None:
        self._halt_event.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join()
        self._thread = None
        self.reset_status()
