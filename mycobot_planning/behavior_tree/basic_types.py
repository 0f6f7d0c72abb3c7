"""Node statuses, node types and port directions, with BehaviorTree.CPP's names and values.

The values are BT.CPP's own (IDLE=0 ... SKIPPED=4) because Groot2's monitor protocol and log
files carry them as numbers; the string forms are the ones BT.CPP prints and parses.
"""
from __future__ import annotations

import enum


class NodeStatus(enum.IntEnum):
    """What a node answers when ticked (IDLE only between executions, never from a tick)."""

    IDLE = 0
    RUNNING = 1
    SUCCESS = 2
    FAILURE = 3
    SKIPPED = 4

    def __str__(self) -> str:
        return self.name


IDLE = NodeStatus.IDLE
RUNNING = NodeStatus.RUNNING
SUCCESS = NodeStatus.SUCCESS
FAILURE = NodeStatus.FAILURE
SKIPPED = NodeStatus.SKIPPED


def is_status_active(status: NodeStatus) -> bool:
    """BT.CPP's isStatusActive: neither IDLE nor SKIPPED."""
    return status is not IDLE and status is not SKIPPED


def is_status_completed(status: NodeStatus) -> bool:
    """BT.CPP's isStatusCompleted: SUCCESS or FAILURE."""
    return status is SUCCESS or status is FAILURE


class NodeType(enum.Enum):
    """The kind of a node; the value is the XML tag of the generic form (``<Action ID=...>``)."""

    UNDEFINED = "Undefined"
    ACTION = "Action"
    CONDITION = "Condition"
    CONTROL = "Control"
    DECORATOR = "Decorator"
    SUBTREE = "SubTree"

    def __str__(self) -> str:
        return self.value

    @classmethod
    def from_tag(cls, tag: str) -> NodeType:
        """The type a generic tag names, UNDEFINED for any other tag (a compact-form node)."""
        return _TAG_TYPES.get(tag, cls.UNDEFINED)


_TAG_TYPES = {t.value: t for t in NodeType if t is not NodeType.UNDEFINED}


class PortDirection(enum.Enum):
    """Input, output or both; the value is the TreeNodesModel element name."""

    INPUT = "input_port"
    OUTPUT = "output_port"
    INOUT = "inout_port"

    def __str__(self) -> str:
        return {"input_port": "Input", "output_port": "Output", "inout_port": "InOut"}[self.value]


class PreCond(enum.IntEnum):
    """Pre-condition attributes; the order is the order BT.CPP evaluates them in."""

    FAILURE_IF = 0
    SUCCESS_IF = 1
    SKIP_IF = 2
    WHILE_TRUE = 3

    @property
    def attribute(self) -> str:
        return PRE_CONDITION_NAMES[self]


class PostCond(enum.IntEnum):
    """Post-condition attributes (``_onHalted`` runs when the node is halted)."""

    ON_HALTED = 0
    ON_FAILURE = 1
    ON_SUCCESS = 2
    ALWAYS = 3

    @property
    def attribute(self) -> str:
        return POST_CONDITION_NAMES[self]


PRE_CONDITION_NAMES = ("_failureIf", "_successIf", "_skipIf", "_while")
POST_CONDITION_NAMES = ("_onHalted", "_onFailure", "_onSuccess", "_post")


def is_reserved_attribute(name: str) -> bool:
    """Attributes that are never ports: name, ID, _autoremap and the pre/post conditions."""
    return name in _RESERVED


def is_allowed_port_name(name: str) -> bool:
    """BT.CPP's IsAllowedPortName: starts with a letter and is not reserved."""
    return bool(name) and name[0].isascii() and name[0].isalpha() and name not in _RESERVED


_RESERVED = frozenset(("name", "ID", "_autoremap", *PRE_CONDITION_NAMES, *POST_CONDITION_NAMES))
