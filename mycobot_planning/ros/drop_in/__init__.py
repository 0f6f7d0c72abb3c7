"""MoveIt's Python modules, served by this package, for scripts written against MoveIt.

A script written for MTC's ROS 2 bindings or for MoveItPy imports ``moveit.task_constructor``,
``moveit.planning``, ``moveit.core.*``, py_binding_tools' ``rclcpp`` and ROS 1's
``moveit_commander``. None of those is installed here (and nothing of that name is put into
site-packages, so a machine that has the real ones keeps them): :func:`install` puts an import
hook first on ``sys.meta_path`` that answers those names with the modules of this package
(``moveit`` -> ``mycobot_planning.ros.drop_in.moveit``, ...). Only the script runner
(``ros2 run mycobot_planning mtc_script SCRIPT.py``, see :mod:`.runner`) installs it.

The full story: docs/moveit_py.md.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
from types import ModuleType
from typing import Sequence

__all__ = ["ALIASES", "DropInFinder", "install", "installed", "uninstall"]

#: top-level module name a script imports -> the module of ours that answers it
ALIASES = {
    "moveit": f"{__name__}.moveit",
    "rclcpp": f"{__name__}.rclcpp",
    "moveit_commander": f"{__name__}.moveit_commander",
}


class _AliasLoader(importlib.abc.Loader):
    """Loads an alias as the module it stands for (one module object under two names)."""

    def __init__(self, target: str) -> None:
        self.target = target

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return importlib.import_module(self.target)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing: the target module ran when it was imported under its own name."""


class DropInFinder(importlib.abc.MetaPathFinder):
    """Finds ``moveit``, ``rclcpp``, ``moveit_commander`` and their submodules in this package."""

    def find_spec(self, fullname: str, path: Sequence[str] | None = None, target: ModuleType | None = None
                  ) -> importlib.machinery.ModuleSpec | None:
        top, dot, rest = fullname.partition(".")
        if top not in ALIASES:
            return None
        real = ALIASES[top] + dot + rest
        if importlib.util.find_spec(real) is None:
            return None  # ModuleNotFoundError under the name the script used
        return importlib.util.spec_from_loader(fullname, _AliasLoader(real))


_FINDER = DropInFinder()


def install() -> None:
    """Answer MoveIt's module names from here, before any other finder (idempotent)."""
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def uninstall() -> None:
    """Remove the hook (modules already imported under the aliases stay in sys.modules)."""
    while _FINDER in sys.meta_path:
        sys.meta_path.remove(_FINDER)


def installed() -> bool:
    return _FINDER in sys.meta_path
