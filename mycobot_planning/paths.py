"""Where the package's data lives, whether run from a checkout, an editable install or colcon.

The robot description and YAML files ship in ``config/``; colcon installs them to
``share/mycobot_planning/config``. Everything that needs a default file asks here, so there is
one rule for finding them.
"""
from __future__ import annotations

import sys
from pathlib import Path

PACKAGE = "mycobot_planning"


def config_dir() -> Path:
    """The folder holding mycobot_280.urdf, the SRDF and the YAML parameter files."""
    candidates = [
        Path(__file__).resolve().parent.parent / "config",  # checkout / editable install
        Path(sys.prefix) / "share" / PACKAGE / "config",  # pip or colcon install
    ]
    for candidate in candidates:
        if (candidate / "mycobot_280.urdf").is_file():
            return candidate
    raise FileNotFoundError(
        f"{PACKAGE}: config folder not found (looked in {', '.join(str(c) for c in candidates)})"
    )


def config_file(name: str) -> Path:
    """A file in config/, with an error that names it if it is missing."""
    path = config_dir() / name
    if not path.is_file():
        raise FileNotFoundError(f"{PACKAGE}: no config file '{name}' in {path.parent}")
    return path


def example_robot_data_dir() -> Path:
    """The robots/ folder of the example-robot-data wheel (test and benchmark robots)."""
    for base in [Path(p) for p in sys.path if p] + [Path(sys.prefix)]:
        candidate = base / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError("example-robot-data is not installed (pip install example-robot-data)")
