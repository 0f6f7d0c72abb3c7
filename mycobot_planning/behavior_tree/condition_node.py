"""Condition nodes (BT.CPP's condition_node.h): leaves that check and answer at once."""
from __future__ import annotations

from collections.abc import Callable

from .action_node import as_status
from .basic_types import NodeStatus, NodeType
from .tree_node import NodeConfig, TreeNode


class ConditionNode(TreeNode):
    """A leaf that only checks something: SUCCESS or FAILURE, nothing to halt."""

    NODE_TYPE = NodeType.CONDITION

    def halt(self) -> None:
        self.reset_status()


class SimpleConditionNode(ConditionNode):
    """A function as a condition: ``f(node) -> NodeStatus`` (or bool)."""

    def __init__(self, name: str, config: NodeConfig, tick_functor: Callable[[TreeNode], NodeStatus | bool]):
        super().__init__(name, config)
        self._tick_functor = tick_functor

    def tick(self) -> NodeStatus:
        return as_status(self._tick_functor(self), f"condition [{self.name}]")
