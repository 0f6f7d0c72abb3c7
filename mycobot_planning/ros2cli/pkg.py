"""`ros2 pkg executables | prefix | list`, from the ament index and pip's metadata (see _ament)."""
from __future__ import annotations

import argparse
from typing import Any

from . import _ament
from . import _common as c


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "pkg", "Various package related sub-commands")

    p = c.add_verb(verbs, "executables", "Output a list of package specific executables", executables)
    p.add_argument("package_name", nargs="?", help="The package name")
    p.add_argument("--full-path", action="store_true", help="Output full path of executables")

    p = c.add_verb(verbs, "prefix", "Output the prefix path of a package", prefix)
    p.add_argument("package_name", help="The package name")
    p.add_argument("--share", action="store_true", help="Show share directory for the package")

    c.add_verb(verbs, "list", "Output a list of available packages", list_packages)


def _describe(package_name: str, executable: _ament.Executable, full_path: bool) -> str:
    if full_path:
        return str(executable.path) if executable.path is not None else f"{executable.name} ({executable.entry_point})"
    return f"{package_name} {executable.name}"


def executables(args: argparse.Namespace) -> int | str:
    names = [args.package_name] if args.package_name else _ament.package_names()
    for package_name in sorted(names):
        try:
            found = _ament.executables(package_name)
        except _ament.PackageNotFound:
            return f"Package '{package_name}' not found"
        for executable in found:
            print(_describe(package_name, executable, args.full_path))
    return 0


def prefix(args: argparse.Namespace) -> int | str:
    path = _ament.package_share_directory(args.package_name) if args.share else _ament.package_prefix(args.package_name)
    if path is None:
        return "Package not found"
    print(path)
    return 0


def list_packages(args: argparse.Namespace) -> int:
    for name in _ament.package_names():
        print(name)
    return 0
