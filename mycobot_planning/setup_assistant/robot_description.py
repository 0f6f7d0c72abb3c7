"""The robot's URDF text from a .urdf or a .urdf.xacro file (ROS's xacro, from PyPI)."""
from __future__ import annotations

import io
from contextlib import redirect_stderr
from pathlib import Path

from ..core.errors import RobotModelError


def read_robot_description(path: Path, xacro_args: dict[str, str]) -> str:
    """URDF text; xacro files are expanded with `xacro_args` as their `name:=value` arguments."""
    if not path.is_file():
        raise RobotModelError(f"robot description '{path}' does not exist")
    if path.suffix != ".xacro":
        try:
            return path.read_text()
        except OSError as exc:
            raise RobotModelError(f"cannot read URDF '{path}': {exc}") from None
    import xacro

    errors = io.StringIO()
    try:
        with redirect_stderr(errors):  # xacro prints its own diagnostics; we report them once
            document = xacro.process_file(str(path), mappings=dict(xacro_args))
    except Exception as exc:  # xacro raises XacroException, XML errors, KeyError for $(arg) ...
        detail = errors.getvalue().strip()
        raise RobotModelError(f"xacro cannot expand '{path}': {exc}" + (f" ({detail})" if detail else "")) from None
    return document.toprettyxml(indent="  ")
