"""`ros2 interface show | list | package | packages`: interface definitions from the ament index.

The ROS wheels install the .msg/.srv files under `<prefix>/share/<pkg>/`, as a ROS install does;
nested types are expanded with one tab per level, as ros2cli (Jazzy) prints them. Lines are
classified with rosidl_adapter's parser (in the wheels) so that comments and nested types are
recognised exactly as ros2cli does.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Iterator

from . import _ament
from . import _common as c

SEPARATORS = ("---",)


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "interface", "Show information about ROS interfaces")

    p = c.add_verb(verbs, "show", "Output the interface definition", show)
    group = p.add_mutually_exclusive_group()
    group.add_argument("--all-comments", action="store_true", help="Show all comments, including for nested interface definitions")
    group.add_argument("--no-comments", action="store_true", help="Show no comments or whitespace")
    p.add_argument("type", help="Show an interface definition (e.g. 'example_interfaces/msg/String'). "
                                "Passing '-' reads the argument from stdin (e.g. "
                                "'ros2 topic type /chatter | ros2 interface show -').")

    p = c.add_verb(verbs, "list", "List all interface types available", list_interfaces)
    p.add_argument("-m", "--only-msgs", action="store_true", help="Print out only the messages")
    p.add_argument("-s", "--only-srvs", action="store_true", help="Print out only the services")
    p.add_argument("-a", "--only-actions", action="store_true", help="Print out only the actions")

    p = c.add_verb(verbs, "package", "Output a list of available interface types within one package", package)
    p.add_argument("package_name", help="Package name")

    p = c.add_verb(verbs, "packages", "Output a list of packages that provide interfaces", packages)
    p.add_argument("-m", "--only-msgs", action="store_true", help="Only list packages that generate messages")
    p.add_argument("-s", "--only-srvs", action="store_true", help="Only list packages that generate services")
    p.add_argument("-a", "--only-actions", action="store_true", help="Only list packages that generate actions")


def _interface_path(identifier: str) -> Path:
    parts = identifier.split("/")
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"Invalid name '{identifier}'. Expected three parts separated by '/'")
    package_name, kind, name = parts
    prefix = _ament.package_prefix(package_name)
    if prefix is None:
        raise LookupError(f"Unknown package '{package_name}'")
    path = prefix / "share" / package_name / kind / f"{name}.{kind}"
    if not path.is_file():
        raise LookupError(f"Could not find the interface '{path}'")
    return path


class _Line:
    """One line of an interface file: raw text, whether it is a comment, and its nested type."""

    def __init__(self, package_name: str, msg_name: str, text: str) -> None:
        from rosidl_adapter.parser import parse_message_string

        self.text = text
        self.field = None
        self.comment_only = False
        if text.strip() in SEPARATORS:
            return
        spec = parse_message_string(pkg_name=package_name, msg_name=msg_name, message_string=text)
        if spec.fields:
            self.field = spec.fields[0]
        elif spec.constants:
            pass
        else:
            self.comment_only = bool(spec.annotations.get("comment"))

    @property
    def trailing_comment(self) -> str | None:
        if self.field is not None and self.field.annotations.get("comment"):
            return self.field.annotations["comment"][0]
        return None

    @property
    def nested_type(self) -> str | None:
        if self.field is None or "/" not in str(self.field.type):
            return None
        type_text = str(self.field.type)
        if self.field.type.is_array:
            type_text = type_text[:type_text.find("[")]
        return type_text.replace("/", "/msg/")


def _lines(identifier: str) -> Iterator[_Line]:
    path = _interface_path(identifier)
    package_name, _, name = identifier.split("/")
    with open(path, encoding="utf-8") as handle:
        for raw in handle:
            yield _Line(package_name, name, raw.rstrip())


def _show(identifier: str, show_comments: bool, show_nested_comments: bool, indent: int = 0) -> None:
    for line in _lines(identifier):
        text = line.text
        if not show_comments:
            if not text or line.comment_only:
                continue
            trailing = line.trailing_comment
            if trailing:
                text = text[:text.find(trailing) - 1].strip()
        print(f"{indent * chr(9)}{text}" if text else "")
        if line.nested_type:
            _show(line.nested_type, show_nested_comments, show_nested_comments, indent + 1)


def show(args: argparse.Namespace) -> int | str:
    identifier = args.type
    if identifier == "-":
        if sys.stdin.isatty():
            return "expected stdin pipe"
        identifier = sys.stdin.readline().strip()
    if not identifier:
        return "the passed value is empty"
    try:
        _show(identifier, not args.no_comments, args.all_comments)
    except (ValueError, LookupError) as exc:
        return str(exc)
    return 0


def _package_interfaces(package_name: str) -> list[str]:
    prefix = _ament.package_prefix(package_name)
    if prefix is None:
        raise LookupError(f"Unknown package '{package_name}'")
    index = prefix / "share" / "ament_index" / "resource_index" / "rosidl_interfaces" / package_name
    if not index.is_file():
        return []
    names = set()
    for entry in index.read_text().splitlines():
        stem, _, ext = entry.rpartition(".")
        if ext in ("msg", "srv", "action", "idl") and "_" not in stem:  # as rosidl_runtime_py
            names.add(f"{package_name}/{stem}")
    return sorted(names)


def _interface_packages() -> list[str]:
    found = set()
    for prefix in _ament.search_prefixes():
        index = prefix / "share" / "ament_index" / "resource_index" / "rosidl_interfaces"
        if index.is_dir():
            found.update(p.name for p in index.iterdir())
    return sorted(found)


def _kind_filter(args: argparse.Namespace) -> set[str]:
    kinds = {k for k, flag in (("msg", args.only_msgs), ("srv", args.only_srvs), ("action", args.only_actions)) if flag}
    return kinds or {"msg", "srv", "action"}


def list_interfaces(args: argparse.Namespace) -> int:
    kinds = _kind_filter(args)
    titles = {"msg": "Messages:", "srv": "Services:", "action": "Actions:"}
    for kind in ("msg", "srv", "action"):
        if kind not in kinds:
            continue
        print(titles[kind])
        for package_name in _interface_packages():
            for name in _package_interfaces(package_name):
                if name.split("/")[1] == kind:
                    print(f"    {name}")
    return 0


def package(args: argparse.Namespace) -> int | str:
    try:
        names = _package_interfaces(args.package_name)
    except LookupError:
        return f"Unknown package '{args.package_name}'"
    for name in names:
        print(name)
    return 0


def packages(args: argparse.Namespace) -> int:
    kinds = _kind_filter(args)
    for package_name in _interface_packages():
        if any(name.split("/")[1] in kinds for name in _package_interfaces(package_name)):
            print(package_name)
    return 0
