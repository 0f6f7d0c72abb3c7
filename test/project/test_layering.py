"""The layers, read statically from the source: nothing below the nodes imports rclpy, and the
runtime library never imports the demos or the bench (MTC keeps its demos in a demo package,
MoveIt its benchmarks in moveit_ros_benchmarks). Only the seed demos' thin node entry points
reach into mycobot_planning.demos."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import mycobot_planning

ROOT = Path(mycobot_planning.__file__).parent
PACKAGE = "mycobot_planning"
#: Layers that must run without ROS.
ROS_FREE = ("core", "task", "perception", "capabilities", "mock_control", "visualization", "behavior_tree")
#: Not part of the runtime library.
OUTSIDE_RUNTIME = ("demos", "bench")
#: The seeds' demo programs as nodes: entry points that build a demo and run it.
SEED_ENTRY_POINTS = {
    "nodes/mtc_node.py", "nodes/pick_place_demo.py", "nodes/modular.py", "nodes/fallbacks_move_to.py",
    "nodes/ik_clearance_cost.py", "nodes/move_group_exercise_1_1.py", "nodes/move_group_exercise_1_2.py",
    "nodes/fake_marker_publisher.py", "nodes/part_localizer.py",
}


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


def _files(*layers: str) -> list[Path]:
    return sorted(p for layer in layers for p in (ROOT / layer).rglob("*.py"))


@pytest.mark.parametrize("path", _files(*ROS_FREE), ids=lambda p: str(p.relative_to(ROOT)))
def test_layers_below_the_nodes_never_import_rclpy(path):
    ros = {m for m in _imports(path) if m.split(".")[0] in ("rclpy", "rcl_interfaces")}
    assert not ros, f"{path.relative_to(ROOT)} imports {sorted(ros)}"


def test_the_runtime_never_imports_demos_or_bench():
    offenders = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in OUTSIDE_RUNTIME or str(rel) in SEED_ENTRY_POINTS:
            continue
        bad = {m for m in _imports(path) if any(m == f"{PACKAGE}.{o}" or m.startswith(f"{PACKAGE}.{o}.")
                                                for o in OUTSIDE_RUNTIME)}
        if bad:
            offenders[str(rel)] = sorted(bad)
    assert not offenders, offenders


def test_demos_do_not_climb_into_the_nodes():
    """Demos build on the library and its clients, not on node internals."""
    offenders = {str(p.relative_to(ROOT)): sorted(m for m in _imports(p) if m.startswith(f"{PACKAGE}.nodes"))
                 for p in _files("demos")}
    assert not any(offenders.values()), offenders


def test_seed_entry_points_stay_thin_and_exist():
    for rel in SEED_ENTRY_POINTS:
        lines = (ROOT / rel).read_text().count("\n")
        assert lines < 250, f"{rel} has {lines} lines: move its logic into demos/ or the library"
