"""The control nodes of BehaviorTree.CPP 4.6-4.8, with its exact tick semantics
(src/controls/*.cpp of BT.CPP): Sequence, AsyncSequence, SequenceWithMemory, ReactiveSequence,
Fallback, AsyncFallback, ReactiveFallback, Parallel, ParallelAll, IfThenElse, WhileDoElse and
Switch2..Switch6. docs/behavior_tree.md tells each one's rules in prose.
"""
from __future__ import annotations

import re

from .basic_types import FAILURE, IDLE, RUNNING, SKIPPED, SUCCESS, NodeStatus, is_status_active
from .control_node import ControlNode
from .exceptions import LogicError
from .ports import INT, STRING, input_port, parse_int
from .tree_node import NodeConfig, TreeNode


def _idle_child(node: ControlNode) -> LogicError:
    return LogicError(f"[{node.name}]: a child should not return IDLE")


class _OrderedControl(ControlNode):
    """Children in order: ADVANCE moves on to the next child, STOP ends the execution with that
    status, RUNNING is resumed at the same child next tick. Sequence and Fallback are the two
    mirror images (BT.CPP's SequenceNode and FallbackNode)."""

    ADVANCE = SUCCESS
    STOP = FAILURE
    #: keep the index after STOP: the next tick resumes at the child that stopped
    MEMORY = False

    def __init__(self, name: str, config: NodeConfig | None = None, make_async: bool = False):
        super().__init__(name, config)
        self._current = 0
        self._skipped = 0
        self._async = make_async

    def halt(self) -> None:
        if not self.MEMORY:  # BT.CPP's SequenceWithMemory keeps its place when halted too
            self._current = 0
            self._skipped = 0
        ControlNode.halt(self)

    def tick(self) -> NodeStatus:
        children = self.children
        count = len(children)
        advance, stop = self.ADVANCE, self.STOP
        if not is_status_active(self._status):
            self._skipped = 0
        self.set_status(RUNNING)
        while self._current < count:
            child = children[self._current]
            previous = child._status
            status = child.execute_tick()
            if status is RUNNING:
                return RUNNING
            if status is stop:
                if self.MEMORY:
                    for index in range(self._current, count):
                        self.halt_child(index)
                else:
                    self.reset_children()
                    self._current = 0
                return stop
            if status is advance:
                self._current += 1
                if self._async and self._wake_up is not None and previous is IDLE and self._current < count:
                    # return the flow between children, so that the tree can be interrupted
                    self.emit_wake_up_signal()
                    return RUNNING
            elif status is SKIPPED:
                self._current += 1
                self._skipped += 1
            else:
                raise _idle_child(self)
        all_skipped = self._skipped == count
        if self._current == count:
            self.reset_children()
            self._current = 0
            self._skipped = 0
        return SKIPPED if all_skipped else advance


class SequenceNode(_OrderedControl):
    """Children in order while they succeed; a RUNNING child is ticked again next time (the
    ones before it are not); a FAILURE resets the sequence to its first child. The async
    variant returns RUNNING after each child that succeeded at once, so that the tree can be
    interrupted between children."""


class SequenceWithMemoryNode(_OrderedControl):
    """A Sequence that does not start over after a FAILURE: the next tick resumes at the child
    that failed (the children after it are halted). Like BT.CPP's, it returns the flow after
    each child that succeeded at once."""

    MEMORY = True

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config, make_async=True)


class FallbackNode(_OrderedControl):
    """Children in order until one succeeds; a RUNNING child is ticked again next time; all
    failing is FAILURE. The async variant yields after each child that failed at once."""

    ADVANCE = FAILURE
    STOP = SUCCESS


class _ReactiveControl(ControlNode):
    """Every tick starts again from the first child; a RUNNING child halts every other child;
    STOP halts all. ReactiveSequence and ReactiveFallback are the mirror images."""

    ADVANCE = SUCCESS
    STOP = FAILURE

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._running_child = -1

    def tick(self) -> NodeStatus:
        all_skipped = True
        if self._status is IDLE:
            self._running_child = -1
        self.set_status(RUNNING)
        children = self.children
        advance, stop = self.ADVANCE, self.STOP
        for index, child in enumerate(children):
            status = child.execute_tick()
            all_skipped = all_skipped and status is SKIPPED
            if status is RUNNING:
                for other in range(len(children)):
                    if other != index:
                        self.halt_child(other)
                if self._running_child == -1:
                    self._running_child = index
                return RUNNING
            if status is stop:
                self.reset_children()
                return stop
            if status is SKIPPED:
                self.halt_child(index)  # so that it can be skipped again
            elif status is not advance:
                raise _idle_child(self)
        self.reset_children()
        return SKIPPED if all_skipped else advance

    def halt(self) -> None:
        self._running_child = -1
        ControlNode.halt(self)


class ReactiveSequenceNode(_ReactiveControl):
    """Every tick starts again from the first child (conditions are re-checked); a child that
    is RUNNING halts every other child; FAILURE halts all."""


class ReactiveFallbackNode(_ReactiveControl):
    """Every tick starts again from the first child; a RUNNING child halts the others; the first
    SUCCESS halts all and succeeds."""

    ADVANCE = FAILURE
    STOP = SUCCESS


def threshold(value: int, children: int) -> int:
    """BT.CPP's Parallel thresholds: a negative value counts from the number of children,
    Python-style (-1 = all of them, -2 = all but one)."""
    return max(children + value + 1, 0) if value < 0 else value


class ParallelNode(ControlNode):
    """Ticks every child that has not completed, on every tick. SUCCESS once ``success_count``
    children succeeded, FAILURE once ``failure_count`` failed or success became impossible;
    the running children are then halted. Negative counts: -1 = all children."""

    @classmethod
    def provided_ports(cls):
        return (input_port("success_count", INT, -1, "number of children that need to succeed to trigger a SUCCESS"),
                input_port("failure_count", INT, 1, "number of children that need to fail to trigger a FAILURE"))

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._completed: set[int] = set()
        self._success_count = 0
        self._failure_count = 0
        self.success_threshold = -1
        self.failure_threshold = 1

    def validate(self) -> None:
        count = len(self.children)
        for port in ("success_count", "failure_count"):
            text = self.config.input_ports.get(port, "")
            if text and not text.strip().startswith("{"):
                if count < threshold(parse_int(text), count):
                    kind = "succeed" if port == "success_count" else "fail"
                    raise LogicError(f"{port}={text} but only {count} children: the Parallel can never {kind}")

    def tick(self) -> NodeStatus:
        self.success_threshold = self.get_input("success_count")
        self.failure_threshold = self.get_input("failure_count")
        children = self.children
        count = len(children)
        required_success = threshold(self.success_threshold, count)
        required_failure = threshold(self.failure_threshold, count)
        if count < required_success:
            raise LogicError("Number of children is less than threshold. Can never succeed.")
        if count < required_failure:
            raise LogicError("Number of children is less than threshold. Can never fail.")
        self.set_status(RUNNING)
        skipped = 0
        for index, child in enumerate(children):
            if index not in self._completed:
                status = child.execute_tick()
                if status is SKIPPED:
                    skipped += 1
                elif status is SUCCESS:
                    self._completed.add(index)
                    self._success_count += 1
                elif status is FAILURE:
                    self._completed.add(index)
                    self._failure_count += 1
                elif status is not RUNNING:
                    raise _idle_child(self)
            if (self._success_count >= required_success
                    or (self.success_threshold < 0 and self._success_count + skipped >= required_success)):
                self._clear()
                self.reset_children()
                return SUCCESS
            if count - self._failure_count < required_success or self._failure_count == required_failure:
                self._clear()
                self.reset_children()
                return FAILURE
        return SKIPPED if skipped == count else RUNNING

    def _clear(self) -> None:
        self._completed.clear()
        self._success_count = 0
        self._failure_count = 0

    def halt(self) -> None:
        self._clear()
        ControlNode.halt(self)


class ParallelAllNode(ControlNode):
    """Ticks every child until all have completed; FAILURE if at least ``max_failures`` of
    them failed (negative: counted from the number of children), else SUCCESS."""

    @classmethod
    def provided_ports(cls):
        return (input_port("max_failures", INT, 1,
                           "If the number of children returning FAILURE exceeds this value, ParallelAll returns FAILURE"),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._completed: set[int] = set()
        self._failure_count = 0

    def validate(self) -> None:
        text = self.config.input_ports.get("max_failures", "")
        if text and not text.strip().startswith("{"):
            if len(self.children) < threshold(parse_int(text), len(self.children)):
                raise LogicError(f"max_failures={text} but only {len(self.children)} children: "
                                 "the ParallelAll can never fail")

    def tick(self) -> NodeStatus:
        children = self.children
        count = len(children)
        failure_threshold = threshold(self.get_input("max_failures"), count)
        if count < failure_threshold:
            raise LogicError("Number of children is less than threshold. Can never fail.")
        self.set_status(RUNNING)
        skipped = 0
        for index, child in enumerate(children):
            if index in self._completed:
                continue
            status = child.execute_tick()
            if status is SUCCESS:
                self._completed.add(index)
            elif status is FAILURE:
                self._completed.add(index)
                self._failure_count += 1
            elif status is SKIPPED:
                skipped += 1
            elif status is not RUNNING:
                raise _idle_child(self)
        if skipped == count:
            return SKIPPED
        if skipped + len(self._completed) >= count:
            self.halt_children()
            self._completed.clear()
            status = FAILURE if self._failure_count >= failure_threshold else SUCCESS
            self._failure_count = 0
            return status
        return RUNNING

    def halt(self) -> None:
        self._completed.clear()
        self._failure_count = 0
        ControlNode.halt(self)


class _ConditionalBranches(ControlNode):
    """A condition (child 1), a then-branch (child 2) and an optional else-branch (child 3)."""

    CHILDREN = (2, 3)

    def _start_tick(self, kind: str) -> list[TreeNode]:
        """The children, checked to be 2 or 3 (a LogicError naming ``kind`` if not), with the
        node set RUNNING."""
        children = self.children
        if len(children) not in (2, 3):
            raise LogicError(f"{kind} must have either 2 or 3 children")
        self.set_status(RUNNING)
        return children


class IfThenElseNode(_ConditionalBranches):
    """Child 1 is the condition: SUCCESS ticks child 2, FAILURE ticks child 3 (or fails if
    there is none). The condition is not ticked again while the chosen branch runs."""

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._child_index = 0

    def halt(self) -> None:
        self._child_index = 0
        ControlNode.halt(self)

    def tick(self) -> NodeStatus:
        children = self._start_tick("IfThenElseNode")
        count = len(children)
        if self._child_index == 0:
            condition = children[0].execute_tick()
            if condition is RUNNING:
                return RUNNING
            if condition is SUCCESS:
                self._child_index = 1
            elif condition is FAILURE:
                if count == 3:
                    self._child_index = 2
                else:
                    return FAILURE
        if self._child_index > 0:
            status = children[self._child_index].execute_tick()
            if status is RUNNING:
                return RUNNING
            self.reset_children()
            self._child_index = 0
            return status
        raise LogicError("Something unexpected happened in IfThenElseNode (the condition was SKIPPED?)")


class WhileDoElseNode(_ConditionalBranches):
    """Like IfThenElse, but the condition is ticked on every tick: when it changes, the branch
    that was running is halted."""

    def tick(self) -> NodeStatus:
        children = self._start_tick("WhileDoElseNode")
        count = len(children)
        condition = children[0].execute_tick()
        if condition is RUNNING:
            return RUNNING
        status = IDLE
        if condition is SUCCESS:
            if count == 3:
                self.halt_child(2)
            status = children[1].execute_tick()
        elif condition is FAILURE:
            if count == 3:
                self.halt_child(1)
                status = children[2].execute_tick()
            else:
                status = FAILURE
        if status is RUNNING:
            return RUNNING
        self.reset_children()
        if status is IDLE:
            raise LogicError("WhileDoElseNode: the condition returned SKIPPED")
        return status


def check_string_equality(v1: str, v2: str, enums) -> bool:
    """BT.CPP's Switch comparison: equal strings, or equal integers (enum names allowed), or
    reals within the float epsilon. Numbers are read as ``from_chars`` reads them: no spaces,
    but here also no trailing characters (BT.CPP 4.10 rejects those too)."""
    if v1 == v2:
        return True

    def to_int(text: str) -> int | None:
        if enums and text in enums:
            return int(enums[text])
        return int(text) if _INTEGER.fullmatch(text) else None

    a, b = to_int(v1), to_int(v2)
    if a is not None and b is not None and a == b:
        return True
    if not (_REAL.fullmatch(v1) and _REAL.fullmatch(v2)):
        return False
    x, y = float(v1), float(v2)
    return abs(x - y) <= 1.1920928955078125e-07


_INTEGER = re.compile(r"-?[0-9]+")
_REAL = re.compile(r"-?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


class SwitchNode(ControlNode):
    """``variable`` is compared with ``case_1``..``case_N``; the first equal case's child is
    ticked, else the last child (the default). A running child whose case no longer matches is
    halted."""

    NUM_CASES = 2

    @classmethod
    def provided_ports(cls):
        ports = [input_port("variable", STRING)]
        ports += [input_port(f"case_{i}", STRING, required=False) for i in range(1, cls.NUM_CASES + 1)]
        return ports

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._running_child = -1
        self._case_keys = [f"case_{i}" for i in range(1, self.NUM_CASES + 1)]

    def halt(self) -> None:
        self._running_child = -1
        ControlNode.halt(self)

    def tick(self) -> NodeStatus:
        if len(self.children) != self.NUM_CASES + 1:
            raise LogicError("Wrong number of children in SwitchNode; must be (num_cases + default)")
        match_index = self.NUM_CASES
        variable = self.get_input("variable", None)
        if variable is not None:
            enums = self.config.enums
            for index, key in enumerate(self._case_keys):
                value = self.get_input(key, None)
                if value is not None and check_string_equality(variable, value, enums):
                    match_index = index
                    break
        if self._running_child != -1 and self._running_child != match_index:
            self.halt_child(self._running_child)
        status = self.children[match_index].execute_tick()
        if status is SKIPPED:
            self._running_child = -1
            return SKIPPED
        if status is RUNNING:
            self._running_child = match_index
        else:
            self.reset_children()
            self._running_child = -1
        return status


def switch_class(cases: int) -> type[SwitchNode]:
    """Switch2 .. Switch6."""
    return type(f"Switch{cases}Node", (SwitchNode,),
                {"NUM_CASES": cases, "CHILDREN": (cases + 1, cases + 1), "__doc__": SwitchNode.__doc__})


__all__ = [
    "SequenceNode", "SequenceWithMemoryNode", "ReactiveSequenceNode", "FallbackNode", "ReactiveFallbackNode",
    "ParallelNode", "ParallelAllNode", "IfThenElseNode", "WhileDoElseNode", "SwitchNode", "switch_class",
    "threshold", "check_string_equality",
]
