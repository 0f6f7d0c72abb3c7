"""The built-in actions and conditions of BehaviorTree.CPP 4.6-4.8 (actions/*.h): AlwaysSuccess,
AlwaysFailure, Script, ScriptCondition, SetBlackboard, UnsetBlackboard, Sleep and
WasEntryUpdated."""
from __future__ import annotations

from .action_node import StatefulActionNode, SyncActionNode
from .basic_types import FAILURE, RUNNING, SUCCESS, NodeStatus
from .blackboard import EMPTY
from .condition_node import ConditionNode
from .decorators import _ScriptPort, entry_key_of
from .exceptions import BehaviorTreeRuntimeError
from .ports import (
    ANY,
    ANY_VALUE,
    STRING,
    UINT,
    ConversionError,
    bidirectional_port,
    input_port,
    parse_bool,
    parse_double,
    parse_int,
    strip_blackboard_pointer,
)
from .scripting import script_truth
from .tree_node import NodeConfig


class AlwaysSuccessNode(SyncActionNode):
    """SUCCESS."""

    def tick(self) -> NodeStatus:
        return SUCCESS


class AlwaysFailureNode(SyncActionNode):
    """FAILURE."""

    def tick(self) -> NodeStatus:
        return FAILURE


class ScriptNode(SyncActionNode):
    """Runs the script ``code`` on the blackboard; SUCCESS (an error in the script is an error
    of the tree, not a FAILURE)."""

    @classmethod
    def provided_ports(cls):
        return (input_port("code", STRING, description="Piece of code that can be parsed"),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._script = _ScriptPort(self, "code")

    def tick(self) -> NodeStatus:
        self._script.run()
        return SUCCESS


class ScriptConditionNode(ConditionNode):
    """SUCCESS if the script ``code`` is true, FAILURE if it is false."""

    @classmethod
    def provided_ports(cls):
        return (input_port("code", ANY, description="Piece of code that can be parsed. Must return false or true"),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._script = _ScriptPort(self, "code")

    def tick(self) -> NodeStatus:
        return SUCCESS if script_truth(self._script.run()) else FAILURE


class SetBlackboardNode(SyncActionNode):
    """Writes ``value`` (a literal, or the value of another entry ``{key}``) into the entry
    named by ``output_key`` (a key name, not ``{key}``). A literal written to an entry that
    has a type, or holds a number or a bool, is converted to it."""

    @classmethod
    def provided_ports(cls):
        return (input_port("value", ANY, description="Value to be written into the output_key"),
                bidirectional_port("output_key", ANY,
                                   description="Name of the blackboard entry where the value should be written"))

    def tick(self) -> NodeStatus:
        output_key = self.get_input("output_key")
        if not isinstance(output_key, str) or not output_key:
            raise BehaviorTreeRuntimeError(f"SetBlackboard: output_key must name an entry, got {output_key!r}")
        value_text = self.config.input_ports["value"]
        blackboard = self.config.blackboard
        destination = blackboard.get_entry(output_key)
        source_key = strip_blackboard_pointer(value_text)
        if source_key:
            source = blackboard.get_entry(source_key)
            if source is None:
                raise BehaviorTreeRuntimeError(f"SetBlackboard: can't find the entry [{source_key}] "
                                               "referred by [value]")
            if destination is None:
                destination = blackboard.create_entry(output_key, source.type)
            value = source.value
        else:
            value = value_text
        if value is EMPTY:
            return FAILURE
        if destination is not None and isinstance(value, str):
            try:
                if destination.type.strongly_typed and destination.type.name != STRING.name:
                    value = destination.type.from_string(value)
                elif isinstance(destination.value, bool):
                    value = parse_bool(value)
                elif isinstance(destination.value, int):
                    value = parse_int(value, -(2 ** 63), 2 ** 63 - 1)
                elif isinstance(destination.value, float):
                    value = parse_double(value)
            except ConversionError as exc:
                raise BehaviorTreeRuntimeError(f"SetBlackboard: can't convert string [{value}] to the type of "
                                               f"[{output_key}]: {exc}") from None
        blackboard.set(output_key, value)
        return SUCCESS


class UnsetBlackboardNode(SyncActionNode):
    """Removes the entry ``key`` from this (sub)tree's blackboard."""

    @classmethod
    def provided_ports(cls):
        return (input_port("key", STRING, description="Key of the entry to remove"),)

    def tick(self) -> NodeStatus:
        self.config.blackboard.unset(self.get_input("key"))
        return SUCCESS


class SleepNode(StatefulActionNode):
    """RUNNING for ``msec`` milliseconds of the tree's clock, then SUCCESS."""

    @classmethod
    def provided_ports(cls):
        return (input_port("msec", UINT),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._deadline = 0.0

    def on_start(self) -> NodeStatus:
        msec = self.get_input("msec")
        if msec <= 0:
            return SUCCESS
        self._deadline = self.now() + msec / 1000.0
        self.wake_up_at(self._deadline)
        return RUNNING

    def on_running(self) -> NodeStatus:
        return SUCCESS if self.now() >= self._deadline else RUNNING

    def on_halted(self) -> None:
        self._deadline = 0.0


class WasEntryUpdatedNode(SyncActionNode):
    """SUCCESS if ``entry`` was written since this node last checked it, else FAILURE."""

    @classmethod
    def provided_ports(cls):
        return (input_port("entry", ANY_VALUE, description="Entry to check"),)

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self._key = entry_key_of(self.config, name)
        self._sequence_id = 0

    def tick(self) -> NodeStatus:
        entry = self.config.blackboard.get_entry(self._key)
        if entry is None:
            return FAILURE
        previous, self._sequence_id = self._sequence_id, entry.sequence_id
        return SUCCESS if previous != entry.sequence_id else FAILURE
