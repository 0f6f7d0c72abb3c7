"""The package's modules import each other without a circle, without imports hidden inside
functions to dodge one, and without reaching for another module's private names (MTC keeps
storage.h apart from stage.h for the same reason; moveit_core's directories depend one way).

Read statically from the source. The graph is what Python executes at import time:
module-level imports (``if TYPE_CHECKING:`` blocks excluded), and for ``import a.b.c`` also the
``__init__`` of every package on the way that is not already being imported around the
importer (its own parent packages are). ``from p import name`` needs ``p`` complete when
``name`` is not a submodule, even when ``p`` is the importer's own parent package."""
from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path

import pytest

import mycobot_planning

ROOT = Path(mycobot_planning.__file__).parent
PACKAGE = "mycobot_planning"
#: Layers the function-import and private-name rules cover (the cycle rule covers the package).
CHECKED_LAYERS = ("core", "capabilities", "task", "ros", "benchmarks")

#: Imports inside a function that are lazy for a reason other than a cycle: (module, imported
#: module) -> why.
LAZY_IMPORTS: dict[tuple[str, str], str] = {}

#: Imports of another module's private (underscore) names, each a debt to pay off: the test
#: fails when one is added, and when one listed here is gone (so the list only shrinks).
PRIVATE_IMPORTS: dict[tuple[str, str], str] = {}


@dataclass
class Module:
    name: str
    path: Path
    is_package: bool
    edges: set[str] = field(default_factory=set)
    lazy: list[tuple[int, str]] = field(default_factory=list)
    private: list[tuple[int, str]] = field(default_factory=list)


def _name(path: Path) -> str:
    return ".".join((PACKAGE, *path.relative_to(ROOT).with_suffix("").parts)).removesuffix(".__init__")


def _type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and (
        (isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING")
        or (isinstance(node.test, ast.Attribute) and node.test.attr == "TYPE_CHECKING"))


def _base(module: Module, node: ast.ImportFrom) -> str:
    if node.level == 0:
        return node.module or ""
    anchor = module.name.split(".") if module.is_package else module.name.split(".")[:-1]
    anchor = anchor[: len(anchor) - (node.level - 1)]
    return ".".join(anchor + ([node.module] if node.module else []))


def _module_level(tree: ast.Module):
    """Statements run at import time: the body, the bodies of if/try blocks, not functions."""
    pending = list(tree.body)
    while pending:
        node = pending.pop()
        if _type_checking(node):
            pending.extend(node.orelse)
            continue
        if isinstance(node, (ast.If, ast.Try, ast.With)):
            for part in ("body", "orelse", "finalbody", "handlers"):
                pending.extend(getattr(node, part, []))
        elif isinstance(node, ast.ExceptHandler):
            pending.extend(node.body)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node


def _ancestors(name: str) -> list[str]:
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def _load() -> dict[str, Module]:
    modules = {}
    for path in sorted(ROOT.rglob("*.py")):
        module = Module(_name(path), path, path.name == "__init__.py")
        modules[module.name] = module
    for module in modules.values():
        tree = ast.parse(module.path.read_text(), filename=str(module.path))
        own = set(_ancestors(module.name)) | ({module.name} if module.is_package else set())

        def need(target: str, complete: bool) -> None:
            # the packages on the way run their __init__ unless one is around the importer already
            for package in _ancestors(target):
                if package in modules and package not in own:
                    module.edges.add(package)
            if target in modules and target != module.name and (complete or target not in own):
                module.edges.add(target)

        for node in _module_level(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    need(alias.name, complete=False)
            else:
                base = _base(module, node)
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    if sub in modules:
                        need(sub, complete=True)
                    else:
                        need(base, complete=True)
        for node in ast.walk(tree):  # anywhere, type-checking blocks and functions included
            if isinstance(node, ast.ImportFrom):
                base = _base(module, node)
                for alias in node.names:
                    sub = f"{base}.{alias.name}"
                    own_private_module = sub in modules and base in own
                    if alias.name.startswith("_") and not alias.name.startswith("__") \
                            and base.startswith(PACKAGE) and not own_private_module:
                        module.private.append((node.lineno, sub))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for inner in ast.walk(node):
                    if isinstance(inner, ast.Import):
                        module.lazy.extend((inner.lineno, a.name) for a in inner.names)
                    elif isinstance(inner, ast.ImportFrom):
                        module.lazy.append((inner.lineno, _base(module, inner)))
    return modules


MODULES = _load()


def _checked(module: Module) -> bool:
    return any(module.name == f"{PACKAGE}.{layer}" or module.name.startswith(f"{PACKAGE}.{layer}.")
               for layer in CHECKED_LAYERS)


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


def test_the_layers_exist():
    for layer in CHECKED_LAYERS:
        assert f"{PACKAGE}.{layer}" in MODULES, layer


def test_no_import_cycle_at_run_time():
    cycle = _cycle({name: module.edges for name, module in MODULES.items()})
    assert cycle is None, " -> ".join(cycle)


@pytest.mark.parametrize("layer", CHECKED_LAYERS)
def test_no_import_hidden_inside_a_function(layer):
    found = [f"{m.name}:{line} imports {target}" for m in MODULES.values() if _checked(m)
             and m.name.split(".")[1] == layer for line, target in m.lazy if (m.name, target) not in LAZY_IMPORTS]
    assert found == [], "import at module level (or name the reason in LAZY_IMPORTS):\n" + "\n".join(found)


def test_listed_lazy_imports_are_still_there():
    present = {(m.name, target) for m in MODULES.values() for _, target in m.lazy}
    assert set(LAZY_IMPORTS) <= present, set(LAZY_IMPORTS) - present


def test_no_import_of_another_modules_private_names():
    found = {(m.name, target) for m in MODULES.values() if _checked(m) for _, target in m.private}
    assert found - set(PRIVATE_IMPORTS) == set(), "private names imported:\n" + "\n".join(sorted(
        f"{a} imports {b}" for a, b in found - set(PRIVATE_IMPORTS)))
    assert set(PRIVATE_IMPORTS) - found == set(), "paid off, drop from PRIVATE_IMPORTS: " + str(
        set(PRIVATE_IMPORTS) - found)


def test_the_cycle_check_finds_a_circle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_a_package_init_that_imports_a_user_of_the_package_is_a_cycle():
    """core.planners.ompl needs core.planning_interface complete: were that package's __init__ to
    import the pipeline (which imports the planners), importing the OMPL planner first would fail."""
    ompl = MODULES[f"{PACKAGE}.core.planners.ompl.planner_manager"]
    assert f"{PACKAGE}.core.planning_interface" in ompl.edges
    graph = {name: set(module.edges) for name, module in MODULES.items()}
    graph[f"{PACKAGE}.core.planning_interface"].add(f"{PACKAGE}.core.planning_interface.planning_pipeline")
    assert _cycle(graph) is not None


CAPABILITIES_PACKAGE = f"{PACKAGE}.capabilities"
#: capabilities/ modules that are no capability: the context, the JSON face, the IK solver cache,
#: the trajectory cache the plan and Cartesian path capabilities consult.
CAPABILITY_SUPPORT = {"move_group_context", "json_face", "state_queries", "trajectory_cache"}
#: the faces that translate to the capabilities' typed calls
FACES = (f"{CAPABILITIES_PACKAGE}.json_face", f"{PACKAGE}.ros.move_group.move_group")


def _capability_modules() -> set[str]:
    return {name.rsplit(".", 1)[1] for name in MODULES if name.startswith(f"{CAPABILITIES_PACKAGE}.")
            } - CAPABILITY_SUPPORT


def test_every_capability_module_is_listed():
    from mycobot_planning.capabilities import CAPABILITIES

    assert _capability_modules() == set(CAPABILITIES)


@pytest.mark.parametrize("face", FACES)
def test_both_faces_call_every_capability(face):
    """A new capability is one module that both faces pick up (and nothing else to edit in core)."""
    missing = {c for c in _capability_modules() if f"{CAPABILITIES_PACKAGE}.{c}" not in MODULES[face].edges}
    assert missing == set(), f"{face} does not call {sorted(missing)}"


def test_capabilities_depend_on_the_context_and_the_core_not_on_a_face():
    faces = set(FACES) | {name for name in MODULES if name.startswith(f"{PACKAGE}.ros.")}
    for name in _capability_modules() | {"move_group_context"}:
        module = MODULES[f"{CAPABILITIES_PACKAGE}.{name}"]
        assert not module.edges & faces, f"{module.name} imports a face: {sorted(module.edges & faces)}"
    context = MODULES[f"{CAPABILITIES_PACKAGE}.move_group_context"]
    capabilities = {f"{CAPABILITIES_PACKAGE}.{c}" for c in _capability_modules()}
    assert not context.edges & capabilities, "the context must not import the capabilities that use it"


def test_the_pipeline_dispatches_through_the_planner_registry():
    """No planner is named by the capabilities or the faces: they read the registry."""
    planners = {name for name in MODULES if name.startswith(f"{PACKAGE}.core.planners.")
                and not name.startswith(f"{PACKAGE}.core.planners.cartesian")}
    for name, module in MODULES.items():
        if name.startswith(f"{CAPABILITIES_PACKAGE}.") or name.startswith(f"{PACKAGE}.ros.move_group."):
            assert not module.edges & planners, f"{name} imports {sorted(module.edges & planners)}"
