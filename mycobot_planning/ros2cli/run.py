"""`ros2 run [--prefix P] <pkg> <executable> [args...]`.

Finds the executable as ros2cli does (`<prefix>/lib/<pkg>/<exe>` through the ament index) and, in
a pip install, among the console_scripts of the package's distribution (see _ament). Everything
after the executable name, `--ros-args -p k:=v --params-file f.yaml` included, is passed through
untouched.

Unlike ros2cli, which waits on a child process, we replace this process with the executable
(exec): Ctrl-C and SIGTERM reach the node directly and `$!` in a shell script is the node's PID.
"""
from __future__ import annotations

import argparse
import os
import shlex
import sys
from typing import Any

from . import _ament


def register(subparsers: Any) -> None:
    p = subparsers.add_parser("run", help="Run a package specific executable")
    p.add_argument("--prefix", help="Prefix command, which should go before the executable. "
                                     "Command must be wrapped in quotes if it contains spaces "
                                     "(e.g. --prefix 'gdb -ex run --args').")
    p.add_argument("package_name", help="Name of the ROS package")
    p.add_argument("executable_name", help="Name of the executable")
    p.add_argument("argv", nargs=argparse.REMAINDER,
                   help="Pass arbitrary arguments to the executable")
    p.set_defaults(func=run)


def command_for(package_name: str, executable_name: str) -> list[str]:
    """The command line that runs the executable. Raises RuntimeError with ros2cli's sentences."""
    try:
        found = [e for e in _ament.executables(package_name) if e.name == executable_name]
    except _ament.PackageNotFound:
        raise RuntimeError(f"Package '{package_name}' not found") from None
    if not found:
        raise RuntimeError("No executable found")
    files = [e for e in found if e.path is not None]
    if len(files) > 1:
        raise RuntimeError("Multiple executables found:" + "".join(f"\n- {e.path}" for e in files))
    executable = files[0] if files else found[0]
    if executable.path is not None:
        return [str(executable.path)]
    # an entry point whose script is not installed (e.g. declared but not reinstalled): load it
    code = ("import sys; from importlib.metadata import EntryPoint; "
            f"sys.argv[0] = {executable.name!r}; "
            f"sys.exit(EntryPoint(name={executable.name!r}, value={executable.entry_point!r}, "
            "group='console_scripts').load()())")
    return [sys.executable, "-c", code]


def run(args: argparse.Namespace) -> int | str:
    try:
        command = command_for(args.package_name, args.executable_name)
    except RuntimeError as exc:
        return str(exc)
    argv = list(args.argv)
    if argv[:1] == ["--"]:
        argv = argv[1:]
    if args.prefix:
        command = shlex.split(args.prefix) + command
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        os.execvp(command[0], command + argv)
    except OSError as exc:
        return f"Failed to run '{command[0]}': {exc.strerror}"
    return 0  # not reached
