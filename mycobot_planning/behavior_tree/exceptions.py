"""Errors of the behavior-tree engine, named after BehaviorTree.CPP's (BehaviorTreeException,
LogicError, RuntimeError), plus the one a user meets most: a tree refused at load time, which
names the file, the line and the node so the XML can be fixed without a debugger."""
from __future__ import annotations


class BehaviorTreeException(Exception):
    """Base of every error the engine raises on purpose."""


class LogicError(BehaviorTreeException):
    """A programming error in a node or in the engine's use (BT.CPP's LogicError)."""


class BehaviorTreeRuntimeError(BehaviorTreeException):
    """Something failed while the tree ran; ``node_path`` names the node when known."""

    def __init__(self, message: str, node_path: str | None = None):
        super().__init__(message)
        self.message = message
        self.node_path = node_path

    def __str__(self) -> str:
        if self.node_path:
            return f"node '{self.node_path}': {self.message}"
        return self.message


class PortError(BehaviorTreeRuntimeError):
    """A port could not be read or written (missing entry, value of the wrong type)."""


class TreeLoadError(BehaviorTreeException):
    """A tree refused before anything ran: where (file, line, node) and why.

    ``unknown_node_id`` is set when the reason is a node ID nobody registered, so that a caller
    (the run_objective command) can say which service would know that node.
    """

    def __init__(self, message: str, *, file: str | None = None, line: int | None = None,
                 node: str | None = None, unknown_node_id: str | None = None):
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.node = node
        self.unknown_node_id = unknown_node_id

    def __str__(self) -> str:
        where = self.file or "<xml>"
        if self.line is not None:
            where += f":{self.line}"
        if self.node:
            return f"{where}: {self.node}: {self.message}"
        return f"{where}: {self.message}"


class ScriptError(BehaviorTreeException):
    """A script that does not parse (``column`` is 1-based) or that fails when evaluated."""

    def __init__(self, message: str, script: str = "", column: int | None = None):
        super().__init__(message)
        self.message = message
        self.script = script
        self.column = column

    def __str__(self) -> str:
        at = f" at column {self.column}" if self.column is not None else ""
        return f"{self.message}{at} in script [{self.script}]" if self.script else self.message


class ScriptSyntaxError(ScriptError):
    """The script text is not in BT.CPP's scripting language."""
