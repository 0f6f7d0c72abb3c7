"""The decorator nodes of BehaviorTree.CPP 4.6-4.8 with its tick semantics
(src/decorators/*.cpp, include/behaviortree_cpp/decorators/*.h): Inverter, ForceSuccess,
ForceFailure, Repeat, RetryUntilSuccessful, KeepRunningUntilFailure, Delay, Timeout, RunOnce,
Precondition, LoopInt/LoopBool/LoopDouble/LoopString, SkipUnlessUpdated, WaitValueUpdate and
SubTree.

Delay and Timeout read the tree's clock and ask the tree to wake up when their time is up,
instead of BT.CPP's timer threads: the child is halted by the first tick at or after the
deadline, which the tick loop schedules at the deadline itself.
"""
from __future__ import annotations

from collections import deque
from typing import Any, ClassVar

from .basic_types import FAILURE, IDLE, RUNNING, SKIPPED, SUCCESS, NodeStatus, NodeType, is_status_completed
from .blackboard import EMPTY
from .decorator_node import DecoratorNode
from .exceptions import LogicError
from .ports import (
    ANY_VALUE,
    BOOL,
    DOUBLE,
    INT,
    NODE_STATUS,
    QUEUE_BOOL,
    QUEUE_DOUBLE,
    QUEUE_INT,
    QUEUE_STRING,
    STRING,
    UINT,
    PortType,
    bidirectional_port,
    input_port,
    is_blackboard_pointer,
    output_port,
    remapped_key,
    strip_blackboard_pointer,
)
from .scripting import Environment, Script, parse_script, script_truth
from .tree_node import NodeConfig


class _CompletedChildMapped(DecoratorNode):
    """Ticks the child; when it answers a status of COMPLETED, the child is reset and the node
    answers what COMPLETED maps it to; any other status goes to :meth:`other`."""

    COMPLETED: ClassVar[dict[NodeStatus, NodeStatus]] = {}

    def tick(self) -> NodeStatus:
        self.set_status(RUNNING)
        status = self.child.execute_tick()
        mapped = self.COMPLETED.get(status)
        if mapped is not None:
            self.reset_child()
            return mapped
        return self.other(status)

    def other(self, status: NodeStatus) -> NodeStatus:
        return status


class InverterNode(_CompletedChildMapped):
    """SUCCESS becomes FAILURE and FAILURE becomes SUCCESS; RUNNING and SKIPPED pass through."""

    COMPLETED = {SUCCESS: FAILURE, FAILURE: SUCCESS}

    def other(self, status: NodeStatus) -> NodeStatus:
        if status is RUNNING or status is SKIPPED:
            return status
        raise LogicError(f"[{self.name}]: a child should not return IDLE")


class _ForcedStatus(_CompletedChildMapped):
    """A completed child is one status (ForceSuccess: SUCCESS), whatever it answered."""

    COMPLETED = {SUCCESS: SUCCESS, FAILURE: SUCCESS}


class ForceSuccessNode(_ForcedStatus):
    """A completed child is SUCCESS, whatever it answered."""


class ForceFailureNode(_ForcedStatus):
    """A completed child is FAILURE, whatever it answered."""

    COMPLETED = {SUCCESS: FAILURE, FAILURE: FAILURE}


class _CountedLoop(DecoratorNode):
    """Ticks the child again while it answers COUNTED, up to the port's number of times (-1:
    forever), within one tick while it answers at once (returning the flow, with a wake-up,
    between two such ticks); the other completed status ends it at once. Repeat counts
    successes, RetryUntilSuccessful failures."""

    PORT = "num_cycles"
    COUNTED = SUCCESS
    #: read the port again after each counted answer (BT.CPP's RetryNode does, RepeatNode not)
    REREAD = False

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._count = 0

    def halt(self) -> None:
        self._count = 0
        DecoratorNode.halt(self)

    def tick(self) -> NodeStatus:
        limit = self.get_input(self.PORT)
        do_loop = self._count < limit or limit == -1
        counted = self.COUNTED
        self.set_status(RUNNING)
        while do_loop:
            previous = self.child._status
            status = self.child.execute_tick()
            if status is counted:
                self._count += 1
                if self.REREAD:
                    limit = self.get_input(self.PORT)
                do_loop = self._count < limit or limit == -1
                self.reset_child()
                if self._wake_up is not None and previous is IDLE and do_loop:
                    self.emit_wake_up_signal()
                    return RUNNING
            elif status is SUCCESS or status is FAILURE:
                self._count = 0
                self.reset_child()
                return status
            elif status is RUNNING:
                return RUNNING
            elif status is SKIPPED:
                self.reset_child()
                return SKIPPED
            else:
                raise LogicError(f"[{self.name}]: a child should not return IDLE")
        self._count = 0
        return counted


class RepeatNode(_CountedLoop):
    """Ticks a succeeding child up to ``num_cycles`` times (-1: forever); a FAILURE stops and
    fails."""

    @classmethod
    def provided_ports(cls):
        return (input_port("num_cycles", INT, description="Repeat a successful child up to N times. "
                                                          "Use -1 to create an infinite loop."),)


class RetryNode(_CountedLoop):
    """Ticks a failing child again, up to ``num_attempts`` attempts in all (-1: forever); the
    first SUCCESS succeeds."""

    PORT = "num_attempts"
    COUNTED = FAILURE
    REREAD = True

    @classmethod
    def provided_ports(cls):
        return (input_port("num_attempts", INT, description="Execute again a failing child up to N times. "
                                                            "Use -1 to create an infinite loop."),)


class KeepRunningUntilFailureNode(_CompletedChildMapped):
    """RUNNING while the child succeeds (it is ticked again next time); FAILURE when it fails."""

    COMPLETED = {FAILURE: FAILURE, SUCCESS: RUNNING}

    def other(self, status: NodeStatus) -> NodeStatus:
        return RUNNING if status is RUNNING else self._status


class DelayNode(DecoratorNode):
    """RUNNING for ``delay_msec`` milliseconds, then ticks the child (and answers its status)."""

    @classmethod
    def provided_ports(cls):
        return (input_port("delay_msec", UINT, description="Tick the child after a few milliseconds"),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._started = False
        self._deadline = 0.0

    def halt(self) -> None:
        self._started = False
        DecoratorNode.halt(self)

    def tick(self) -> NodeStatus:
        msec = self.get_input("delay_msec")
        if not self._started:
            self._started = True
            self._deadline = self.now() + msec / 1000.0
            self.set_status(RUNNING)
            self.wake_up_at(self._deadline)
            return RUNNING
        if self.now() >= self._deadline:
            status = self.child.execute_tick()
            if is_status_completed(status):
                self._started = False
                self.reset_child()
            return status
        return RUNNING


class TimeoutNode(DecoratorNode):
    """Ticks the child; if it is still RUNNING ``msec`` milliseconds after it started, the
    child is halted and the Timeout fails (0: no time limit)."""

    @classmethod
    def provided_ports(cls):
        return (input_port("msec", UINT, description="After a certain amount of time, halt() the child "
                                                     "if it is still running."),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._started = False
        self._deadline: float | None = None

    def tick(self) -> NodeStatus:
        msec = self.get_input("msec")
        if not self._started:
            self._started = True
            self.set_status(RUNNING)
            self._deadline = self.now() + msec / 1000.0 if msec > 0 else None
            if self._deadline is not None:
                self.wake_up_at(self._deadline)
        elif (self._deadline is not None and self.now() >= self._deadline
              and self.child._status is RUNNING):
            self.halt_child()
            self._started = False
            return FAILURE
        status = self.child.execute_tick()
        if is_status_completed(status):
            self._started = False
            self.reset_child()
        return status

    def halt(self) -> None:
        self._started = False
        DecoratorNode.halt(self)


class RunOnceNode(DecoratorNode):
    """Ticks the child until it completes once; afterwards SKIPPED (``then_skip``) or the same
    status again, without ticking it."""

    @classmethod
    def provided_ports(cls):
        return (input_port("then_skip", BOOL, True, "If true, skip after the first execution, otherwise "
                                                    "return the same NodeStatus returned once by the child."),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._already_ticked = False
        self._returned = IDLE

    def tick(self) -> NodeStatus:
        skip = self.get_input("then_skip", True)
        if self._already_ticked:
            return SKIPPED if skip else self._returned
        self.set_status(RUNNING)
        status = self.child.execute_tick()
        if is_status_completed(status):
            self._already_ticked = True
            self._returned = status
            self.reset_child()
        return status


class _ScriptPort:
    """A port holding a script: parsed once when it is a literal, again when its text changes."""

    def __init__(self, node: Any, port: str):
        self._node = node
        self._port = port
        self._source: str | None = None
        self._script: Script | None = None
        text = node.config.input_ports.get(port)
        if text is not None and remapped_key(port, text) is None:
            self.load(text)

    def load(self, source: str) -> Script:
        if source != self._source:
            self._script = parse_script(source)
            self._source = source
        return self._script

    def current(self) -> Script:
        return self.load(self._node.get_input(self._port))

    def run(self) -> Any:
        """Run the script on the node's blackboard; its last statement's value."""
        config = self._node.config
        return self.current()(Environment(config.blackboard, config.enums))


class PreconditionNode(DecoratorNode):
    """Ticks the child if the script ``if`` is true, else answers ``else``; once the child runs,
    ``if`` is not evaluated again until it completes (BT.CPP 4.7+)."""

    @classmethod
    def provided_ports(cls):
        return (input_port("if", STRING),
                input_port("else", NODE_STATUS, FAILURE, "Return status if condition is false"))

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._script = _ScriptPort(self, "if")
        self._children_running = False

    def tick(self) -> NodeStatus:
        self._script.current()  # loaded on every tick (the script may come from the blackboard)
        else_status = self.get_input("else")
        if not self._children_running:
            self._children_running = script_truth(self._script.run())
            if not self._children_running:
                return else_status
        status = self.child.execute_tick()
        if is_status_completed(status):
            self.reset_child()
            self._children_running = False
        return status

    def halt(self) -> None:
        self._children_running = False
        DecoratorNode.halt(self)


class LoopNode(DecoratorNode):
    """Pops the front of ``queue`` into ``value`` and ticks the child, one element per tick
    (RUNNING in between); ``if_empty`` when the queue is exhausted, FAILURE if the child fails.

    A literal queue (``1;2;3``) starts over at each new execution; a queue in the blackboard is
    consumed (a string entry is parsed once and written back as the remaining elements).
    """

    ELEMENT: PortType = INT
    QUEUE: PortType = QUEUE_INT

    @classmethod
    def provided_ports(cls):
        return (bidirectional_port("queue", cls.QUEUE),
                input_port("if_empty", NODE_STATUS, SUCCESS,
                           "Status to return if queue is empty: SUCCESS, FAILURE, SKIPPED"),
                output_port("value", cls.ELEMENT))

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._child_running = False
        raw = self.config.input_ports.get("queue", "")
        self._static: list | None = None
        if raw and remapped_key("queue", raw) is None:
            self._static = self.QUEUE.from_string(raw)
        self._current: deque | None = None

    def _queue_from_blackboard(self) -> deque | None:
        key = remapped_key("queue", self.get_raw_port_value("queue"))
        entry = self.config.blackboard.get_entry(key) if key else None
        if entry is None or entry.value is EMPTY:
            return None
        value = entry.value
        if isinstance(value, deque):
            return value
        converted = deque(self.QUEUE.convert(value))
        entry.value = converted  # consumed in place from now on, as BT.CPP's shared queue
        entry.touch()
        return converted

    def tick(self) -> NodeStatus:
        popped = False
        if self._status is IDLE:
            self._child_running = False
            if self._static is not None:
                self._current = deque(self._static)
        if not self._child_running:
            if self._static is None:
                self._current = self._queue_from_blackboard()
            if self._current:
                value = self._current.popleft()
                popped = True
                self.set_output("value", value)
        if not popped and not self._child_running:
            return self.get_input("if_empty")
        if self._status is IDLE:
            self.set_status(RUNNING)
        status = self.child.execute_tick()
        self._child_running = status is RUNNING
        if is_status_completed(status):
            self.reset_child()
        if status is FAILURE:
            return FAILURE
        return RUNNING


def loop_class(name: str, element: PortType, queue: PortType) -> type[LoopNode]:
    return type(name, (LoopNode,), {"ELEMENT": element, "QUEUE": queue, "__doc__": LoopNode.__doc__})


LoopIntNode = loop_class("LoopIntNode", INT, QUEUE_INT)
LoopBoolNode = loop_class("LoopBoolNode", BOOL, QUEUE_BOOL)
LoopDoubleNode = loop_class("LoopDoubleNode", DOUBLE, QUEUE_DOUBLE)
LoopStringNode = loop_class("LoopStringNode", STRING, QUEUE_STRING)


def entry_key_of(config: NodeConfig, name: str) -> str:
    """The entry an ``entry`` port names: ``{key}`` or a bare key."""
    raw = config.input_ports.get("entry", "")
    if not raw:
        raise LogicError(f"Missing port 'entry' in {name}")
    return strip_blackboard_pointer(raw) if is_blackboard_pointer(raw) else raw


class EntryUpdatedDecorator(DecoratorNode):
    """Ticks the child only if ``entry`` was written since the last time it was checked;
    otherwise SKIPPED (SkipUnlessUpdated) or RUNNING (WaitValueUpdate)."""

    IF_NOT_UPDATED = SKIPPED

    @classmethod
    def provided_ports(cls):
        return (input_port("entry", ANY_VALUE, description="Entry to check"),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._key = entry_key_of(self.config, name)
        self._sequence_id = 0
        self._still_executing = False

    def tick(self) -> NodeStatus:
        if self._still_executing:
            status = self.child.execute_tick()
            self._still_executing = status is RUNNING
            return status
        entry = self.config.blackboard.get_entry(self._key)
        if entry is None:
            return self.IF_NOT_UPDATED
        previous, self._sequence_id = self._sequence_id, entry.sequence_id
        if previous == entry.sequence_id:
            return self.IF_NOT_UPDATED
        status = self.child.execute_tick()
        self._still_executing = status is RUNNING
        return status

    def halt(self) -> None:
        self._still_executing = False
        DecoratorNode.halt(self)


class SkipUnlessUpdatedNode(EntryUpdatedDecorator):
    __doc__ = EntryUpdatedDecorator.__doc__
    IF_NOT_UPDATED = SKIPPED


class WaitValueUpdateNode(EntryUpdatedDecorator):
    __doc__ = EntryUpdatedDecorator.__doc__
    IF_NOT_UPDATED = RUNNING


class SubTreeNode(DecoratorNode):
    """The root of a SubTree instance; its child is the subtree's root node, which ticks with
    the subtree's own blackboard."""

    NODE_TYPE = NodeType.SUBTREE

    #: BT.CPP's SubTree model declares this one port (not a PortInfo: it starts with '_')
    AUTOREMAP_DESCRIPTION = "If true, all the ports with the same name will be remapped"

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self.subtree_id = ""
        self.autoremap = False

    def tick(self) -> NodeStatus:
        if self._status is IDLE:
            self.set_status(RUNNING)
        status = self.child.execute_tick()
        if is_status_completed(status):
            self.reset_child()
        return status


