"""``moveit.utils``: MoveItPy's parameter-file helpers, and the one that lets a MoveIt
configuration YAML (the tutorials' ``motion_planning_python_api_tutorial.yaml``: parameters at the
top level, no ``ros__parameters``) be given where ROS expects a parameters file."""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from typing import Any, Mapping, Sequence

import yaml

__all__ = ["create_params_file_from_dict", "get_launch_params_filepaths", "is_ros_params_file", "ros_arguments",
           "ros_params_file"]


def create_params_file_from_dict(params: Mapping[str, Any], node_name: str) -> str:
    """A parameters file giving ``params`` to the node ``node_name``; returns its path."""
    with tempfile.NamedTemporaryFile(mode="w", prefix="launch_params_", suffix=".yaml", delete=False) as handle:
        yaml.safe_dump({node_name: {"ros__parameters": dict(params)}}, handle, default_flow_style=False)
        return handle.name


def get_launch_params_filepaths(cli_args: Sequence[str] | None = None) -> list[str]:
    """The paths after each ``--params-file`` of the command line."""
    args = list(sys.argv if cli_args is None else cli_args)
    return [args[i + 1] for i, value in enumerate(args[:-1]) if value == "--params-file"]


def _has_ros_parameters(data: Any) -> bool:
    if isinstance(data, Mapping):
        return "ros__parameters" in data or any(_has_ros_parameters(v) for v in data.values())
    return False


def is_ros_params_file(path: str | Path) -> bool:
    """Is this a ROS 2 parameters file (``node: ros__parameters: ...``)? False for a plain YAML
    of parameters, such as a MoveIt configuration file. OSError/YAMLError when unreadable."""
    with open(path, encoding="utf-8") as handle:
        return _has_ros_parameters(yaml.safe_load(handle))


def ros_params_file(path: str | Path) -> str:
    """``path`` itself when it is a ROS 2 parameters file; for a plain YAML of parameters, a new
    file giving them to every node (``/**: ros__parameters:``), as MoveItConfigsBuilder's dict
    reaches the node a launch file starts. A file that cannot be read is returned unchanged (ROS
    then says what is wrong with it)."""
    try:
        if is_ros_params_file(path):
            return str(path)
        with open(path, encoding="utf-8") as handle:
            data = yaml.safe_load(handle)
    except (OSError, yaml.YAMLError):
        return str(path)
    if not isinstance(data, Mapping):
        return str(path)
    with tempfile.NamedTemporaryFile(mode="w", prefix=f"{Path(path).stem}_", suffix=".yaml", delete=False) as handle:
        yaml.safe_dump({"/**": {"ros__parameters": dict(data)}}, handle, default_flow_style=False)
        return handle.name


def ros_arguments(argv: Sequence[str]) -> list[str]:
    """``argv`` with every ``--params-file`` that is a plain YAML replaced by its ROS form."""
    out = list(argv)
    for i, value in enumerate(out[:-1]):
        if value == "--params-file":
            out[i + 1] = ros_params_file(out[i + 1])
    return out
