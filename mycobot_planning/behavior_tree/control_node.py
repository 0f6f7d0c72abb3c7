"""ControlNode (BT.CPP's control_node.h): a node with children and the ways to halt them."""
from __future__ import annotations

from .basic_types import RUNNING, NodeType
from .tree_node import TreeNode


class ControlNode(TreeNode):
    """Base of Sequence, Fallback, Parallel, ... ``halt`` halts every running child."""

    NODE_TYPE = NodeType.CONTROL
    #: how many children the XML may give it: (min, max or None)
    CHILDREN: tuple[int, int | None] = (1, None)

    def __init__(self, name: str, config=None):
        super().__init__(name, config)
        self.children: list[TreeNode] = []

    def add_child(self, child: TreeNode) -> None:
        self.children.append(child)

    def children_nodes(self) -> list[TreeNode]:
        return self.children

    def children_count(self) -> int:
        return len(self.children)

    def halt(self) -> None:
        self.reset_children()
        self.reset_status()

    def reset_children(self) -> None:
        """Halt the running children, then set every child IDLE."""
        for child in self.children:
            if child._status is RUNNING:
                child.halt_node()
            child.reset_status()

    def halt_child(self, index: int) -> None:
        child = self.children[index]
        if child._status is RUNNING:
            child.halt_node()
        child.reset_status()

    def halt_children(self) -> None:
        for index in range(len(self.children)):
            self.halt_child(index)
