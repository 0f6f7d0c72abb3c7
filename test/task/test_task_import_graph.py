"""The task package's modules import each other without a circle, and without imports hidden
inside functions to dodge one (MTC keeps storage.h apart from stage.h for the same reason).
Read statically from the source: module-level imports, `if TYPE_CHECKING:` blocks excluded,
package __init__ files (re-export facades) left out of the graph."""
from __future__ import annotations

import ast
from pathlib import Path

import mycobot_planning.task as task_package

ROOT = Path(task_package.__file__).parent
PACKAGE = "mycobot_planning.task"


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join((PACKAGE, *parts)).removesuffix(".__init__")


def _resolve(module: str, node: ast.ImportFrom, is_package: bool) -> list[str]:
    if node.level == 0:
        base = node.module or ""
    else:
        anchor = module.split(".") if is_package else module.split(".")[:-1]
        anchor = anchor[: len(anchor) - (node.level - 1)]
        base = ".".join(anchor + ([node.module] if node.module else []))
    targets = [base] + [f"{base}.{alias.name}" for alias in node.names]
    return [t for t in targets if t.startswith(PACKAGE + ".")]


def _type_checking(node: ast.If) -> bool:
    return isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"


def _graph() -> tuple[dict[str, set[str]], list[str]]:
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    hidden: list[str] = []
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        is_package = path.name == "__init__.py"
        edges: set[str] = set()
        for node in tree.body:
            if isinstance(node, ast.ImportFrom):
                edges.update(t for t in _resolve(name, node, is_package) if t in modules)
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for inner in ast.walk(node):
                    if isinstance(inner, (ast.Import, ast.ImportFrom)):
                        hidden.append(f"{name}:{inner.lineno}")
        if not is_package:
            graph[name] = {e for e in edges if not modules[e].name == "__init__.py"}
    return graph, hidden


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if state.get(nxt) is None:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if state.get(node) is None:
            found = visit(node)
            if found:
                return found
    return None


def test_task_modules_import_each_other_without_a_circle():
    graph, _ = _graph()
    assert f"{PACKAGE}.storage" in graph and f"{PACKAGE}.stage" in graph
    assert f"{PACKAGE}.storage" in graph[f"{PACKAGE}.stage"]
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_no_imports_hidden_inside_functions():
    _, hidden = _graph()
    assert hidden == []


def test_the_cycle_check_finds_a_circle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None
