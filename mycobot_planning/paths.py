"""Where the package's data lives, whether run from a checkout, an editable install or colcon.

The robot description and YAML files ship in ``config/``; colcon installs them to
``share/mycobot_planning/config``. Everything that needs a default file asks here, so there is
one rule for finding them.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any, Callable

import yaml

PACKAGE = "mycobot_planning"


def _ament_share() -> Path | None:
    """share/mycobot_planning of the install the ament index (AMENT_PREFIX_PATH) knows, if any."""
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    except ImportError:
        return None
    try:
        return Path(get_package_share_directory(PACKAGE, print_warning=False))
    except (PackageNotFoundError, KeyError, ValueError, OSError, LookupError):
        return None


def config_dir() -> Path:
    """The folder holding mycobot_280.urdf, the SRDF and the YAML parameter files."""
    here = Path(__file__).resolve().parent
    candidates = [here.parent / "config"]  # checkout / editable install
    share = _ament_share()  # colcon or `pip install --prefix` install on AMENT_PREFIX_PATH
    if share is not None:
        candidates.append(share / "config")
    # <prefix>/lib/pythonX.Y/site-packages/mycobot_planning -> <prefix>/share/mycobot_planning
    if len(here.parents) >= 4:
        candidates.append(here.parents[3] / "share" / PACKAGE / "config")
    candidates.append(Path(sys.prefix) / "share" / PACKAGE / "config")  # pip install into a venv
    for candidate in candidates:
        if (candidate / "mycobot_280.urdf").is_file():
            return candidate
    raise FileNotFoundError(
        f"{PACKAGE}: config folder not found (looked in {', '.join(str(c) for c in candidates)})"
    )


def read_yaml_file(path: str | Path, error: Callable[[str], Exception], where: str | None = None) -> Any:
    """The parsed content of the YAML file ``path``. When it cannot be read or parsed,
    ``error("cannot read <where>: <reason>")`` is raised (``where``: the path by default)."""
    try:
        return yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise error(f"cannot read {path if where is None else where}: {exc}") from None


def config_file(name: str) -> Path:
    """A file in config/, with an error that names it if it is missing."""
    path = config_dir() / name
    if not path.is_file():
        raise FileNotFoundError(f"{PACKAGE}: no config file '{name}' in {path.parent}")
    return path


def package_share_dirs() -> list[Path]:
    """Where ``package://NAME/...`` resolves, in order: the share/ folder of every
    AMENT_PREFIX_PATH entry, of the Python prefix (the ROS wheels install there) and of every
    cmeel prefix on sys.path (pip's example-robot-data and other cmeel robot packages)."""
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p] + [Path(sys.prefix)]
    prefixes += [Path(p) / "cmeel.prefix" for p in sys.path if p and (Path(p) / "cmeel.prefix").is_dir()]
    out: list[Path] = []
    for prefix in prefixes:
        if prefix / "share" not in out:
            out.append(prefix / "share")
    return out


def example_robot_data_dir() -> Path:
    """The robots/ folder of the example-robot-data wheel (test and benchmark robots)."""
    for base in [Path(p) for p in sys.path if p] + [Path(sys.prefix)]:
        candidate = base / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError("example-robot-data is not installed (pip install example-robot-data)")


def use_fast_discovery() -> None:
    """Point Fast DDS at config/fastdds_discovery.xml (frequent announcements) unless the user
    chose a profile; must run before rclpy.init in the process."""
    if "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ:
        os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(config_file("fastdds_discovery.xml"))
