"""Tree: an instantiated behavior tree and its tick loop (BT.CPP's Tree in bt_factory.h).

``tick_exactly_once`` ticks the root once; ``tick_once`` ticks again at once while a node asks
for it during the tick (an async Sequence yielding between children, a ThreadedAction finishing;
a wake-up asked for before a tick is answered by that tick);
``tick_while_running`` loops until the root completes, sleeping between ticks until the period
ends or a node wakes the tree up. A completed root is reset so the tree can run again.
An error raised by a node halts the whole tree before it reaches the caller: nothing is left
running behind an exception.
"""
from __future__ import annotations

import enum
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from .basic_types import IDLE, RUNNING, NodeStatus, is_status_completed
from .blackboard import Blackboard
from .clock import SystemClock, WakeUpSignal
from .exceptions import BehaviorTreeRuntimeError
from .tree_node import StatusChangeCallback, TreeNode, TreeNodeManifest


class TickOption(enum.Enum):
    EXACTLY_ONCE = 0
    ONCE_UNLESS_WOKEN_UP = 1
    WHILE_RUNNING = 2


@dataclass
class Subtree:
    """One instance of a BehaviorTree in the tree: its blackboard and its nodes."""

    blackboard: Blackboard
    instance_name: str
    tree_id: str
    nodes: list[TreeNode] = field(default_factory=list)


def apply_recursive_visitor(node: TreeNode | None, visitor: Callable[[TreeNode], Any]) -> None:
    """Call ``visitor`` on ``node`` and every node below it, depth first (subtrees included)."""
    if node is None:
        return
    stack = [node]
    while stack:
        current = stack.pop()
        visitor(current)
        stack.extend(reversed(current.children_nodes()))


class Tree:
    """The nodes of an instantiated tree, its blackboards and its clock."""

    def __init__(self, clock: Any = None):
        self.subtrees: list[Subtree] = []
        self.manifests: dict[str, TreeNodeManifest] = {}
        self.builtin_ids: set[str] = set()
        self.clock = clock if clock is not None else SystemClock()
        self._wake_up = WakeUpSignal()
        self._uid_counter = 0

    def get_uid(self) -> int:
        self._uid_counter += 1
        return self._uid_counter

    def initialize(self) -> None:
        for subtree in self.subtrees:
            for node in subtree.nodes:
                node.set_wake_up_instance(self._wake_up)

    # -- access ------------------------------------------------------------------------------

    @property
    def root_node(self) -> TreeNode | None:
        if not self.subtrees or not self.subtrees[0].nodes:
            return None
        return self.subtrees[0].nodes[0]

    def root_blackboard(self) -> Blackboard | None:
        return self.subtrees[0].blackboard if self.subtrees else None

    def nodes(self) -> Iterator[TreeNode]:
        """Every node, depth first from the root (a SubTree's nodes right after it)."""
        found: list[TreeNode] = []
        apply_recursive_visitor(self.root_node, found.append)
        return iter(found)

    def apply_visitor(self, visitor: Callable[[TreeNode], Any]) -> None:
        apply_recursive_visitor(self.root_node, visitor)

    def node_by_path(self, path: str) -> TreeNode | None:
        return next((n for n in self.nodes() if n.full_path == path), None)

    def nodes_named(self, name: str) -> list[TreeNode]:
        return [n for n in self.nodes() if n.name == name]

    def subscribe_to_status_changes(self, callback: StatusChangeCallback) -> Callable[[], None]:
        """``callback(time, node, previous, new)`` for every node; returns the unsubscriber."""
        unsubscribers = [node.subscribe_to_status_change(callback) for node in self.nodes()]

        def unsubscribe() -> None:
            for unsubscriber in unsubscribers:
                unsubscriber()

        return unsubscribe

    # -- ticking -----------------------------------------------------------------------------

    def tick_exactly_once(self) -> NodeStatus:
        return self._tick_root(TickOption.EXACTLY_ONCE, 0.0)

    def tick_once(self) -> NodeStatus:
        return self._tick_root(TickOption.ONCE_UNLESS_WOKEN_UP, 0.0)

    def tick_while_running(self, sleep_time: float = 0.01) -> NodeStatus:
        """Tick until the root completes, sleeping up to ``sleep_time`` s between ticks."""
        return self._tick_root(TickOption.WHILE_RUNNING, sleep_time)

    def _tick_root(self, option: TickOption, sleep_time: float) -> NodeStatus:
        root = self.root_node
        if root is None:
            raise BehaviorTreeRuntimeError("Empty Tree")
        status = IDLE
        try:
            while status is IDLE or (option is TickOption.WHILE_RUNNING and status is RUNNING):
                self._wake_up.clear_due(self.clock)
                status = root.execute_tick()
                while (option is not TickOption.EXACTLY_ONCE and status is RUNNING
                       and self._wake_up.consume(self.clock)):
                    status = root.execute_tick()
                if is_status_completed(status):
                    root.reset_status()
                if status is RUNNING and sleep_time > 0.0:
                    self.sleep(sleep_time)
        except BaseException:
            self.halt_tree()
            raise
        return status

    def sleep(self, timeout: float) -> bool:
        """Sleep up to ``timeout`` s on the tree's clock; True if a node woke the tree up."""
        return self._wake_up.wait(self.clock, timeout)

    def emit_wake_up_signal(self) -> None:
        self._wake_up.emit()

    def halt_tree(self) -> None:
        """Halt every running node (their ``halt``/``on_halted`` and ``_onHalted`` run) and
        leave every node IDLE."""
        root = self.root_node
        if root is None:
            return
        if root.status is RUNNING:
            root.halt_node()

        def halt_leftover(node: TreeNode) -> None:
            if node.status is RUNNING:
                node.halt_node()
            node.reset_status()

        self.apply_visitor(halt_leftover)
