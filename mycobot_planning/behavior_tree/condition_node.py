"""Condition nodes (BT.CPP's condition_node.h): leaves that check and answer at once."""
from __future__ import annotations

from .action_node import TickFunctorNode
from .basic_types import NodeStatus, NodeType
from .tree_node import TreeNode


class ConditionNode(TreeNode):
    """A leaf that only checks something: SUCCESS or FAILURE, nothing to halt."""

    NODE_TYPE = NodeType.CONDITION

    def halt(self) -> None:
        self.reset_status()


class SimpleConditionNode(TickFunctorNode, ConditionNode):
    """A function as a condition: ``f(node) -> NodeStatus`` (or bool)."""

    KIND = "condition"

    def tick(self) -> NodeStatus:
        return self.functor_status()
