"""Objectives as MoveIt Pro keeps them: BehaviorTree XML files in objective library folders,
an objective named by its BehaviorTree ID, run from the command line or a server.

This module is the ROS-free part: finding an objective in the library folders, loading it
with the library (so that SubTrees defined in other files resolve, as MoveIt Pro registers
every objective file), and the root blackboard as JSON.
"""
from __future__ import annotations

import logging
import math
import os
from collections.abc import Iterable, Mapping
from enum import Enum
from pathlib import Path
from typing import Any

from .blackboard import Blackboard
from .bt_factory import BehaviorTreeFactory
from .exceptions import TreeLoadError
from .xml_parsing import parse_xml

_LOG = logging.getLogger("mycobot_planning.behavior_tree")


def default_library_paths() -> list[Path]:
    """config/objectives of the package, when it exists."""
    try:
        from mycobot_planning.paths import config_dir
        folder = config_dir() / "objectives"
    except FileNotFoundError:
        return []
    return [folder] if folder.is_dir() else []


def library_files(paths: Iterable[str | os.PathLike]) -> list[Path]:
    """Every ``*.xml`` below the library folders, in a stable order."""
    files: list[Path] = []
    for folder in paths:
        folder = Path(folder)
        if folder.is_file():
            files.append(folder)
        elif folder.is_dir():
            files.extend(sorted(p for p in folder.rglob("*.xml") if p.is_file()))
    return files


def tree_ids_of(path: Path) -> list[str]:
    """The BehaviorTree IDs a file defines (without loading what it includes)."""
    root = parse_xml(path.read_bytes(), str(path))
    return [e.get("ID") for e in root.children if e.tag == "BehaviorTree" and e.get("ID")]


def find_objective(name: str, paths: Iterable[str | os.PathLike]) -> Path:
    """The library file that defines BehaviorTree ``name`` (or whose file name is ``name``)."""
    files = library_files(paths)
    by_id: dict[str, list[Path]] = {}
    by_stem: dict[str, list[Path]] = {}
    for path in files:
        try:
            ids = tree_ids_of(path)
        except (TreeLoadError, OSError) as exc:
            _LOG.warning("objective library: skipping %s: %s", path, exc)
            continue
        for tree_id in ids:
            by_id.setdefault(tree_id, []).append(path)
        by_stem.setdefault(path.stem, []).append(path)
    found = by_id.get(name) or by_stem.get(name)
    if not found:
        known = sorted(by_id)
        folders = ", ".join(str(p) for p in paths) or "none"
        raise TreeLoadError(f"no objective named '{name}' in the objective library ({folders}); "
                            f"objectives: {', '.join(known) or 'none'}")
    if len(found) > 1:
        raise TreeLoadError(f"objective '{name}' is defined in more than one file: "
                            + ", ".join(str(p) for p in found))
    return found[0]


def load_objective(factory: BehaviorTreeFactory, target: str, library: Iterable[str | os.PathLike]) -> str:
    """Register the objective ``target`` (a file, or a name in the library) and then the rest of
    the library, whose trees it may use as SubTrees; returns the ID of the tree to run.

    Library files that do not load are skipped with a warning: they only matter if the objective
    uses one of their trees, and then its SubTree is reported missing.
    """
    library = list(library)
    path = Path(target)
    by_name = not (target.endswith(".xml") or path.is_file())
    if by_name:
        path = find_objective(target, library)
    factory.register_behavior_tree_from_file(path)
    tree_id = target if by_name and target in factory.registered_behavior_trees() else factory.parser.main_tree_id()
    own = path.resolve()
    for other in library_files(library):
        if other.resolve() == own:
            continue
        try:
            factory.register_behavior_tree_from_file(other, skip_existing=True)
        except TreeLoadError as exc:
            _LOG.warning("objective library: skipping %s", exc)
    return tree_id


def to_json_value(value: Any) -> Any:
    """A blackboard value as JSON: numbers as numbers, strings as strings, sequences as lists,
    messages as their dicts, anything else as its text."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, Enum):
        return value.name
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, Mapping):
        return {str(k): to_json_value(v) for k, v in value.items()}
    to_dict = getattr(value, "to_dict", None)
    if callable(to_dict):
        return to_json_value(to_dict())
    if isinstance(value, (list, tuple, set, frozenset)) or type(value).__name__ == "deque":
        return [to_json_value(v) for v in value]
    tolist = getattr(value, "tolist", None)
    if callable(tolist):
        return to_json_value(tolist())
    return str(value)


def blackboard_json(blackboard: Blackboard | None) -> dict[str, Any]:
    """The entries a blackboard holds (never-written ones left out), as JSON values."""
    if blackboard is None:
        return {}
    return {key: to_json_value(value) for key, value in sorted(blackboard.items())}
