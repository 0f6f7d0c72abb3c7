"""Where packages and their executables are: the ament index, and pip's metadata as a fallback.

ros2cli finds a package through the ament index (`<prefix>/share/ament_index/resource_index/
packages/<pkg>` under each AMENT_PREFIX_PATH entry) and its executables in `<prefix>/lib/<pkg>/`.
A pip install has no AMENT_PREFIX_PATH, but the ROS wheels do install an ament index into the
venv prefix (that is where std_msgs' .msg files are), so the venv prefix is searched too. Our own
package installed with pip (editable or not) has no `lib/<pkg>/`: its executables are the
console_scripts entry points of its distribution, found with importlib.metadata.
"""
from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

#: Our own entry point: the CLI is not an executable of the package it ships in.
_CLI_ENTRY_POINT = "ros2"


class PackageNotFound(Exception):
    def __init__(self, package_name: str) -> None:
        super().__init__(package_name)
        self.package_name = package_name


@dataclass(frozen=True)
class Executable:
    name: str
    path: Path | None  # a file to exec, or None for an entry point without an installed script
    entry_point: str | None = None  # 'module:function' when it comes from console_scripts


def search_prefixes() -> list[Path]:
    """AMENT_PREFIX_PATH entries in order, then the Python prefix when it holds an ament index."""
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    venv = Path(sys.prefix)
    if (venv / "share" / "ament_index").is_dir() and venv not in prefixes:
        prefixes.append(venv)
    return prefixes


def _index_prefix(package_name: str) -> Path | None:
    for prefix in search_prefixes():
        if (prefix / "share" / "ament_index" / "resource_index" / "packages" / package_name).is_file():
            return prefix
    return None


def _distribution(package_name: str):
    """The installed Python distribution named like the package, if any."""
    from importlib import metadata

    for candidate in {package_name, package_name.replace("_", "-")}:
        try:
            return metadata.distribution(candidate)
        except metadata.PackageNotFoundError:
            continue
    return None


def _distribution_prefix(dist) -> Path:
    """The install prefix of a distribution (the folder holding bin/ and lib/)."""
    location = Path(str(dist.locate_file(""))).resolve()
    venv = Path(sys.prefix).resolve()
    if venv == location or venv in location.parents:
        return Path(sys.prefix)
    for parent in location.parents:
        if parent.name == "lib" or parent.name == "Lib":
            return parent.parent
    return Path(sys.prefix)


def _console_scripts(dist) -> list:
    return sorted(
        (ep for ep in dist.entry_points if ep.group == "console_scripts" and ep.name != _CLI_ENTRY_POINT),
        key=lambda ep: ep.name,
    )


def _is_pip_ros_package(dist) -> bool:
    """A distribution counts as a ROS package when it ships console scripts or a package.xml."""
    if _console_scripts(dist):
        return True
    source = _editable_source(dist)
    return source is not None and (source / "package.xml").is_file()


def _editable_source(dist) -> Path | None:
    """The checkout an editable install points at (PEP 610 direct_url.json), if any."""
    text = dist.read_text("direct_url.json")
    if not text:
        return None
    try:
        info = json.loads(text)
    except ValueError:
        return None
    url = info.get("url", "")
    if info.get("dir_info", {}).get("editable") and url.startswith("file://"):
        return Path(url[len("file://"):])
    return None


def package_prefix(package_name: str) -> Path | None:
    prefix = _index_prefix(package_name)
    if prefix is not None:
        return prefix
    dist = _distribution(package_name)
    if dist is not None and _is_pip_ros_package(dist):
        return _distribution_prefix(dist)
    return None


def package_share_directory(package_name: str) -> Path | None:
    prefix = _index_prefix(package_name)
    if prefix is not None:
        return prefix / "share" / package_name
    dist = _distribution(package_name)
    if dist is None or not _is_pip_ros_package(dist):
        return None
    share = _distribution_prefix(dist) / "share" / package_name
    if share.is_dir():
        return share
    source = _editable_source(dist)  # an editable install keeps package.xml and config/ in the checkout
    return source if source is not None else share


def package_names() -> list[str]:
    names: set[str] = set()
    for prefix in search_prefixes():
        index = prefix / "share" / "ament_index" / "resource_index" / "packages"
        if index.is_dir():
            names.update(p.name for p in index.iterdir() if not p.name.startswith("."))
    from mycobot_planning.paths import PACKAGE

    dist = _distribution(PACKAGE)
    if dist is not None:
        names.add(PACKAGE)
    return sorted(names)


def executables(package_name: str) -> list[Executable]:
    """Executables of a package, sorted by name. Raises PackageNotFound."""
    prefix = _index_prefix(package_name)
    dist = _distribution(package_name)
    if prefix is None and (dist is None or not _is_pip_ros_package(dist)):
        raise PackageNotFound(package_name)
    found: list[Executable] = []
    seen: set[str] = set()
    if prefix is not None:
        base = prefix / "lib" / package_name
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
            for filename in sorted(filenames):
                path = Path(dirpath) / filename
                if os.access(path, os.X_OK):
                    found.append(Executable(filename, path))
                    seen.add(filename)
    if dist is not None:
        scripts_dir = _distribution_prefix(dist) / "bin"
        for ep in _console_scripts(dist):
            if ep.name in seen:
                continue
            script = scripts_dir / ep.name
            found.append(Executable(ep.name, script if os.access(script, os.X_OK) else None, ep.value))
            seen.add(ep.name)
    return sorted(found, key=lambda e: (e.name, str(e.path)))
