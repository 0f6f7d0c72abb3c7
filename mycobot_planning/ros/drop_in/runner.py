"""The script runner: ``ros2 run mycobot_planning mtc_script SCRIPT.py [args] [--ros-args ...]``.

Runs a Python script written for MoveIt (MTC's demo scripts, MoveItPy's tutorials) exactly as
written, as ``python SCRIPT.py`` would: in ``__main__``, with ``sys.argv`` = the script and its
arguments and the script's directory first on ``sys.path``, after installing the import hook that
serves ``moveit``, ``rclcpp`` and ``moveit_commander`` from this package. ``--params-file`` files
that hold plain parameters (a MoveIt configuration YAML such as the tutorials'
``motion_planning_python_api_tutorial.yaml``) are handed on as ROS parameters files for every
node. Exceptions, ``sys.exit`` and the exit code are the script's own.
"""
from __future__ import annotations

import os
import runpy
import sys
from typing import Any, Sequence

from . import install
from .moveit.utils import ros_arguments

USAGE = """usage: mtc_script SCRIPT.py [ARGS ...] [--ros-args ...]

Runs a Python script written for MoveIt's Python APIs (MTC's `moveit.task_constructor`, MoveItPy's
`moveit.planning` / `moveit.core`, py_binding_tools' `rclcpp`, moveit_commander's
PlanningSceneInterface) unchanged, against the running planning_server. A --params-file may be a
ROS parameters file or a plain YAML of parameters (e.g. a MoveItPy configuration)."""


def run_command_line(argv: Sequence[str] | None = None) -> int:
    """mtc_script's command line: usage, a missing script (exit 2), or the script run."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        print(USAGE, file=sys.stdout if args else sys.stderr)
        return 0 if args else 2
    script = args[0]
    if not os.path.isfile(script):
        print(f"mtc_script: no such script: {script}", file=sys.stderr)
        return 2
    run_script(script, args[1:])
    return 0


def run_script(script: str, args: Sequence[str] = ()) -> dict[str, Any]:
    """Run ``script`` as ``__main__`` with the drop-in modules; returns its globals."""
    install()
    sys.argv = [script, *ros_arguments(args)]
    sys.path.insert(0, os.path.dirname(os.path.abspath(script)))
    return runpy.run_path(script, run_name="__main__")
