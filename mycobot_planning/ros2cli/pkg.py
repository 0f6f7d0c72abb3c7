"""`ros2 pkg executables | prefix | list`, from the ament index and pip's metadata (see _ament)."""
from __future__ import annotations

import argparse
from typing import Any

from . import _ament


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser("pkg", help="Various package related sub-commands")
    verbs = parser.add_subparsers(title="Commands", dest="verb", metavar="Call `ros2 pkg <command> -h` for more detailed usage.")
    parser.set_defaults(func=lambda args: parser.print_help() or 0)

    p = verbs.add_parser("executables", help="Output a list of package specific executables")
    p.add_argument("package_name", nargs="?", help="The package name")
    p.add_argument("--full-path", action="store_true", help="Output full path of executables")
    p.set_defaults(func=executables)

    p = verbs.add_parser("prefix", help="Output the prefix path of a package")
    p.add_argument("package_name", help="The package name")
    p.add_argument("--share", action="store_true", help="Show share directory for the package")
    p.set_defaults(func=prefix)

    p = verbs.add_parser("list", help="Output a list of available packages")
    p.set_defaults(func=list_packages)


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
