"""DecoratorNode (BT.CPP's decorator_node.h): a node with exactly one child."""
from __future__ import annotations

from collections.abc import Callable

from .action_node import as_status
from .basic_types import FAILURE, RUNNING, SUCCESS, NodeStatus, NodeType
from .exceptions import LogicError
from .tree_node import NodeConfig, TreeNode


class DecoratorNode(TreeNode):
    """Base of Inverter, Repeat, Timeout, ... A completed child is reset after each tick."""

    NODE_TYPE = NodeType.DECORATOR

    def __init__(self, name: str, config: NodeConfig | None = None):
        super().__init__(name, config)
        self.child: TreeNode | None = None

    def set_child(self, child: TreeNode) -> None:
        if self.child is not None:
            raise LogicError(f"Decorator [{self.name}] has already a child assigned")
        self.child = child

    def children_nodes(self) -> list[TreeNode]:
        return [] if self.child is None else [self.child]

    def halt(self) -> None:
        self.reset_child()
        self.reset_status()

    def halt_child(self) -> None:
        self.reset_child()

    def reset_child(self) -> None:
        child = self.child
        if child is None:
            return
        if child._status is RUNNING:
            child.halt_node()
        child.reset_status()

    def execute_tick(self) -> NodeStatus:
        status = TreeNode.execute_tick(self)
        child = self.child
        if child is not None and (child._status is SUCCESS or child._status is FAILURE):
            child.reset_status()
        return status


class SimpleDecoratorNode(DecoratorNode):
    """A function as a decorator: ``f(child_status, node) -> NodeStatus``."""

    def __init__(self, name: str, config: NodeConfig,
                 tick_functor: Callable[[NodeStatus, TreeNode], NodeStatus | bool]):
        super().__init__(name, config)
        self._tick_functor = tick_functor

    def tick(self) -> NodeStatus:
        return as_status(self._tick_functor(self.child.execute_tick(), self), f"decorator [{self.name}]")
