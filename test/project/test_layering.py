"""The layers, read statically from the source: nothing below the ROS library imports rclpy, the
runtime library never imports the demos or the bench (MTC keeps its demos in a demo package,
MoveIt its benchmarks in moveit_ros_benchmarks), and nodes/ holds one thin main per executable
over the ROS library (mycobot_planning.ros). Only the seed demos' nodes (ros/demos/, and their
mains) reach into mycobot_planning.demos."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import mycobot_planning

ROOT = Path(mycobot_planning.__file__).parent
PACKAGE = "mycobot_planning"
#: Layers that must run without ROS.
ROS_FREE = ("core", "task", "perception", "capabilities", "mock_control", "visualization", "behavior_tree",
            "simulation", "hardware_interface", "hardware", "benchmarks")
#: Not part of the runtime library: the seeds' demos, their nodes, and the benchmarks.
OUTSIDE_RUNTIME = ("demos", "bench", "ros.demos")
#: A thin main: a few lines that start a node the ROS library defines.
THIN_MAIN_LINES = 100
#: Executables that are command-line tools without ROS: their main is their argument handling.
ROS_FREE_TOOLS = {"plot_solution", "run_objective"}
#: ROS modules a ROS-free tool may import inside a function, for an option that needs ROS
#: (run_objective --server); its ROS-free path imports no rclpy (test_run_objective checks it).
ROS_ON_REQUEST = {"run_objective": {"mycobot_planning.ros.objectives.objective_client",
                                    "mycobot_planning.ros.objectives.objective_client.ObjectiveClient"}}


def _module(path: Path) -> str:
    return ".".join((PACKAGE, *path.relative_to(ROOT).with_suffix("").parts)).removesuffix(".__init__")


def _imports(path: Path) -> set[str]:
    """Every module an import statement anywhere in the file names (relative ones resolved)."""
    module = _module(path)
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def _top_level_imports(path: Path) -> set[str]:
    """The modules the file's module-level import statements name (absolute ones)."""
    found: set[str] = set()
    for node in ast.parse(path.read_text(), filename=str(path)).body:
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def _files(*layers: str) -> list[Path]:
    return sorted(p for layer in layers for p in (ROOT / layer).rglob("*.py"))


def _within(module: str, *layers: str) -> bool:
    return any(module == f"{PACKAGE}.{layer}" or module.startswith(f"{PACKAGE}.{layer}.") for layer in layers)


def _nodes() -> list[Path]:
    return [p for p in _files("nodes") if p.name != "__init__.py"]


@pytest.mark.parametrize("path", _files(*ROS_FREE), ids=lambda p: str(p.relative_to(ROOT)))
def test_layers_below_the_nodes_never_import_rclpy(path):
    ros = {m for m in _imports(path) if m.split(".")[0] in ("rclpy", "rcl_interfaces")}
    assert not ros, f"{path.relative_to(ROOT)} imports {sorted(ros)}"


def test_the_runtime_never_imports_demos_or_bench():
    offenders = {}
    for path in sorted(ROOT.rglob("*.py")):
        module = _module(path)
        if _within(module, *OUTSIDE_RUNTIME) or module.startswith(f"{PACKAGE}.nodes."):
            continue
        bad = {m for m in _imports(path) if _within(m, *OUTSIDE_RUNTIME)}
        if bad:
            offenders[str(path.relative_to(ROOT))] = sorted(bad)
    assert not offenders, offenders


def test_demos_do_not_climb_into_the_nodes_or_the_ros_library():
    """Demos build on the library and its clients, not on node internals."""
    offenders = {str(p.relative_to(ROOT)): sorted(m for m in _imports(p) if _within(m, "nodes", "ros"))
                 for p in _files("demos")}
    assert not any(offenders.values()), offenders


def test_nothing_imports_the_executables():
    """nodes/ is the top: its mains are started, never imported by the library."""
    offenders = {str(p.relative_to(ROOT)): sorted(m for m in _imports(p) if _within(m, "nodes"))
                 for p in sorted(ROOT.rglob("*.py")) if not _module(p).startswith(f"{PACKAGE}.nodes")}
    assert not any(offenders.values()), offenders


@pytest.mark.parametrize("path", _nodes(), ids=lambda p: p.name)
def test_nodes_hold_one_thin_main_per_executable(path):
    tree = ast.parse(path.read_text())
    names = {getattr(n, "name", None) for n in tree.body} | {
        t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)}
    assert "main" in names, f"{path.name} has no main"
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)], \
        f"{path.name} defines a class: library code belongs in mycobot_planning.ros"
    if path.stem in ROS_FREE_TOOLS:
        ros = {m for m in _imports(path) if m.split(".")[0] == "rclpy" or _within(m, "ros")}
        assert ros <= ROS_ON_REQUEST.get(path.stem, set()), path.name
        assert not ros & _top_level_imports(path), f"{path.name} imports ROS at module level"
        return
    lines = path.read_text().count("\n")
    assert lines < THIN_MAIN_LINES, f"{path.name} has {lines} lines: move its logic into mycobot_planning.ros"


def test_every_executable_is_a_main_in_nodes_and_every_main_an_executable():
    """setup.py's console_scripts (the `ros2 run` names) point at nodes/ (or at the package's
    tools), and each nodes/ module is one of them under its own name."""
    setup = (ROOT.parent / "setup.py").read_text()
    scripts = dict(re.findall(r'f"(\w+) = \{PACKAGE\}\.([\w.]+):main"', setup))
    in_nodes = {name for name, module in scripts.items() if module.startswith("nodes.")}
    assert {p.stem for p in _nodes()} == in_nodes
    assert all(scripts[name] == f"nodes.{name}" for name in in_nodes)
