"""`ros2 param list | get | set | dump | load | describe | delete`, through the node's parameter
services (rcl_interfaces), with ros2cli's (Jazzy) sentences.

As ros2cli, `set` and `load` print a refusal on stderr and still exit 0. Deliberate differences:
`load` leaves out read-only parameters whose
file value is already the node's (a file from `ros2 param dump` loads back cleanly); `load` takes
the node's own section ('/node' or 'node', plus '/**' with --use-wildcard), not every section.
"""
from __future__ import annotations

import argparse
import re
import sys
from typing import Any

from . import _common as c

SERVICE_TIMEOUT = 5.0


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "param", "Various param related sub-commands")

    def node_arguments(p: argparse.ArgumentParser, optional: bool = False) -> None:
        c.add_spin_time_argument(p)
        p.add_argument("node_name", nargs="?" if optional else None, help="Name of the ROS node")
        p.add_argument("--include-hidden-nodes", action="store_true", help="Consider hidden nodes as well")

    p = c.add_verb(verbs, "list", "Output a list of available parameters", list_parameters)
    node_arguments(p, optional=True)
    p.add_argument("--filter", nargs=1, help="Only parameters matching the regex expression will be showed. Supports `re` regex syntax.")
    p.add_argument("--param-prefixes", nargs="+", default=[], help="Only list parameters with the provided prefixes")
    p.add_argument("--param-type", action="store_true", help="Print parameter types with parameter names")

    p = c.add_verb(verbs, "get", "Get parameter", get)
    node_arguments(p)
    p.add_argument("parameter_name", help="Name of the parameter")
    p.add_argument("--hide-type", action="store_true", help="Hide the type information")

    p = c.add_verb(verbs, "set", "Set parameter", set_parameter)
    node_arguments(p)
    p.add_argument("parameter_name", help="Name of the parameter")
    p.add_argument("value", help="Value of the parameter")

    p = c.add_verb(verbs, "dump", "Show all of the parameters of a node in a YAML file format", dump)
    node_arguments(p)
    p.add_argument("--output-dir", default=".", help=argparse.SUPPRESS)
    p.add_argument("--print", action="store_true", help=argparse.SUPPRESS)

    p = c.add_verb(verbs, "load", "Load parameter file for a node", load)
    node_arguments(p)
    p.add_argument("parameter_file", help="Parameter file")
    p.add_argument("--use-wildcard", action="store_true", help="Load parameters in the '/**' namespace into the node")

    p = c.add_verb(verbs, "describe", "Show descriptive information about declared parameters", describe)
    node_arguments(p)
    p.add_argument("parameter_names", nargs="+", help="Names of the parameters")

    p = c.add_verb(verbs, "delete", "Delete parameter", delete)
    node_arguments(p)
    p.add_argument("parameter_name", help="Name of the parameter")


# ---------------------------------------------------------------------------------------------
# service plumbing


def _call(node: Any, node_name: str, srv_type: Any, suffix: str, request: Any) -> Any:
    client = node.create_client(srv_type, f"{node_name}/{suffix}")
    try:
        if not c.wait_for_service(client, SERVICE_TIMEOUT):
            raise c.CliError("Could not reach parameter services")
        future = client.call_async(request)
        c.spin_until_done(node, future, timeout_sec=SERVICE_TIMEOUT)
        if not future.done():
            raise c.CliError(f"Exception while calling service of node '{node_name}': timed out")
        if future.result() is None:
            raise c.CliError(f"Exception while calling service of node '{node_name}': {future.exception()}")
        return future.result()
    finally:
        node.destroy_client(client)


def call_list_parameters(node: Any, node_name: str, prefixes: list[str] | None = None) -> list[str]:
    from rcl_interfaces.srv import ListParameters

    request = ListParameters.Request(prefixes=list(prefixes or []))
    return list(_call(node, node_name, ListParameters, "list_parameters", request).result.names)


def call_get_parameters(node: Any, node_name: str, names: list[str]) -> list[Any]:
    from rcl_interfaces.srv import GetParameters

    return list(_call(node, node_name, GetParameters, "get_parameters", GetParameters.Request(names=names)).values)


def call_set_parameters(node: Any, node_name: str, parameters: list[Any]) -> list[Any]:
    from rcl_interfaces.srv import SetParameters

    request = SetParameters.Request(parameters=parameters)
    return list(_call(node, node_name, SetParameters, "set_parameters", request).results)


def call_describe_parameters(node: Any, node_name: str, names: list[str]) -> list[Any]:
    from rcl_interfaces.srv import DescribeParameters

    request = DescribeParameters.Request(names=names)
    return list(_call(node, node_name, DescribeParameters, "describe_parameters", request).descriptors)


def parameter_type_string(parameter_type: int) -> str:
    from rcl_interfaces.msg import ParameterType as T

    return {
        T.PARAMETER_BOOL: "boolean", T.PARAMETER_INTEGER: "integer", T.PARAMETER_DOUBLE: "double",
        T.PARAMETER_STRING: "string", T.PARAMETER_BYTE_ARRAY: "byte array",
        T.PARAMETER_BOOL_ARRAY: "boolean array", T.PARAMETER_INTEGER_ARRAY: "integer array",
        T.PARAMETER_DOUBLE_ARRAY: "double array", T.PARAMETER_STRING_ARRAY: "string array",
        T.PARAMETER_NOT_SET: "not set",
    }.get(parameter_type, "unknown")


def _require_node(node: Any, args: argparse.Namespace) -> str:
    name = c.absolute_node_name(args.node_name)
    if not c.wait_for_node(node, name, c.lookup_timeout(args)):
        raise c.CliError("Node not found")
    return name


# ---------------------------------------------------------------------------------------------
# verbs


def list_parameters(args: argparse.Namespace) -> int:
    regex = re.compile(args.filter[0]) if args.filter else None
    with c.CliNode() as node:
        if args.node_name:
            targets = [_require_node(node, args)]
        else:
            targets = c.list_graph(args, lambda: sorted(c.node_names(node, args.include_hidden_nodes)))
        for target in targets:
            try:
                names = sorted(call_list_parameters(node, target, args.param_prefixes))
            except c.CliError as exc:
                print(f"Exception while calling service of node '{target}': {exc}", file=sys.stderr)
                continue
            if regex is not None:
                names = [n for n in names if regex.match(n)]
            if not args.node_name and names:
                print(f"{target}:")
            types = {}
            if args.param_type and names:
                types = {d.name: parameter_type_string(d.type) for d in call_describe_parameters(node, target, names)}
            for name in names:
                print(f"  {name} (type: {types.get(name, 'unknown')})" if args.param_type else f"  {name}")
    return 0


def get(args: argparse.Namespace) -> int | str:
    from rcl_interfaces.msg import ParameterType as T

    with c.CliNode() as node:
        target = _require_node(node, args)
        values = call_get_parameters(node, target, [args.parameter_name])
    if not values:
        return "Parameter not set"
    value = values[0]
    label, field = {
        T.PARAMETER_BOOL: ("Boolean value is:", "bool_value"),
        T.PARAMETER_INTEGER: ("Integer value is:", "integer_value"),
        T.PARAMETER_DOUBLE: ("Double value is:", "double_value"),
        T.PARAMETER_STRING: ("String value is:", "string_value"),
        T.PARAMETER_BYTE_ARRAY: ("Byte values are:", "byte_array_value"),
        T.PARAMETER_BOOL_ARRAY: ("Boolean values are:", "bool_array_value"),
        T.PARAMETER_INTEGER_ARRAY: ("Integer values are:", "integer_array_value"),
        T.PARAMETER_DOUBLE_ARRAY: ("Double values are:", "double_array_value"),
        T.PARAMETER_STRING_ARRAY: ("String values are:", "string_array_value"),
        T.PARAMETER_NOT_SET: ("Parameter not set.", None),
    }.get(value.type, (None, None))
    if label is None:
        return f"Unknown parameter type '{value.type}'"
    content = getattr(value, field) if field else None
    if args.hide_type:
        print(content)
    elif content is None:
        print(label)
    else:
        print(label, content)
    return 0


def set_parameter(args: argparse.Namespace) -> int:
    from rcl_interfaces.msg import Parameter
    from rclpy.parameter import get_parameter_value

    with c.CliNode() as node:
        target = _require_node(node, args)
        parameter = Parameter(name=args.parameter_name, value=get_parameter_value(string_value=args.value))
        results = call_set_parameters(node, target, [parameter])
    result = results[0]
    if result.successful:
        print("Set parameter successful" + (": " + result.reason if result.reason else ""))
        return 0
    print("Setting parameter failed" + (": " + result.reason if result.reason else ""), file=sys.stderr)
    return 0  # as ros2cli: the refusal is reported, the command itself worked


def _insert(tree: dict, dotted: str, value: Any) -> None:
    head, sep, rest = dotted.partition(".")
    if sep:
        _insert(tree.setdefault(head, {}), rest, value)
    else:
        tree[dotted] = value


def dump(args: argparse.Namespace) -> int | str:
    import yaml
    from rclpy.parameter import parameter_value_to_python

    with c.CliNode() as node:
        target = _require_node(node, args)
        names = sorted(call_list_parameters(node, target))
        values = call_get_parameters(node, target, names) if names else []
    parameters: dict = {}
    for name, value in zip(names, values):
        try:
            python_value = parameter_value_to_python(value)
        except RuntimeError as exc:
            print(f"Runtime error {exc} raised")
            python_value = None
        _insert(parameters, name, python_value)
    output = yaml.dump({target: {"ros__parameters": parameters}}, default_flow_style=False)
    if args.output_dir != ".":
        print("WARNING: '--output-dir' is deprecated; use redirection to save to a file", file=sys.stderr)
    print(output)
    return 0


def _flatten(prefix: str, tree: Any, out: dict) -> None:
    if isinstance(tree, dict):
        for key, value in tree.items():
            _flatten(f"{prefix}.{key}" if prefix else str(key), value, out)
    else:
        out[prefix] = tree


def _unchanged_read_only(node: Any, target: str, values: dict) -> list[str]:
    """Read-only parameters whose file value is already the node's value.

    A file made by `ros2 param dump` holds every parameter, read-only ones included (every rclpy
    node has `start_type_description_service`); re-sending those is refused by the node. There is
    nothing to set, so they are left out instead of failing the load.
    """
    from rclpy.parameter import parameter_value_to_python

    declared = set(call_list_parameters(node, target))
    candidates = [name for name in values if name in declared]
    if not candidates:
        return []
    read_only = [d.name for d in call_describe_parameters(node, target, candidates) if d.read_only]
    if not read_only:
        return []
    current = call_get_parameters(node, target, read_only)
    return [name for name, value in zip(read_only, current)
            if parameter_value_to_python(value) == values[name]]


def load(args: argparse.Namespace) -> int | str:
    import yaml
    from rclpy.parameter import Parameter as PyParameter

    try:
        with open(args.parameter_file, "r", encoding="utf-8") as handle:
            content = yaml.safe_load(handle)
    except OSError as exc:
        return f"Cannot read parameter file '{args.parameter_file}': {exc.strerror}"
    except yaml.YAMLError as exc:
        return f"Parameter file '{args.parameter_file}' is not valid YAML: {exc}"
    if not isinstance(content, dict):
        return f"YAML file is not a valid ROS parameter file: '{args.parameter_file}'"

    with c.CliNode() as node:
        target = _require_node(node, args)
        keys = []
        if args.use_wildcard and "/**" in content:
            keys.append("/**")
        keys += [k for k in (target, target.lstrip("/")) if k in content]
        if not keys:
            return (f"Param file does not contain parameters for {target}, "
                    f"only for nodes: {list(content.keys())}")
        flat: dict = {}
        for key in keys:
            section = content[key]
            if not isinstance(section, dict) or "ros__parameters" not in section:
                return (f"Invalid structure of parameter file for node {key}: "
                        "expected same format as provided by ros2 param dump")
            _flatten("", section["ros__parameters"] or {}, flat)
        for name in _unchanged_read_only(node, target, flat):
            del flat[name]
        messages, failures = [], []
        for name, value in flat.items():
            try:
                messages.append(PyParameter(name, value=value).to_parameter_msg())
            except Exception as exc:  # a value ROS parameters cannot hold (e.g. mixed-type list)
                failures.append(f"Set parameter {name} failed: {exc}")
        results = call_set_parameters(node, target, messages) if messages else []
    for message, result in zip(messages, results):
        if result.successful:
            print(f"Set parameter {message.name} successful" + (": " + result.reason if result.reason else ""))
        else:
            print(f"Set parameter {message.name} failed" + (": " + result.reason if result.reason else ""),
                  file=sys.stderr)
    for failure in failures:
        print(failure, file=sys.stderr)
    return 0  # as ros2cli: refusals are reported on stderr, the command itself worked


def describe(args: argparse.Namespace) -> int | str:
    with c.CliNode() as node:
        target = _require_node(node, args)
        descriptors = call_describe_parameters(node, target, args.parameter_names)
    if not descriptors:  # rclpy answers nothing when a name is not declared
        return "Parameter not set"
    for descriptor in descriptors:
        print("Parameter name:", descriptor.name)
        print("  Type:", parameter_type_string(descriptor.type))
        if descriptor.description:
            print("  Description:", descriptor.description)
        print("  Constraints:")
        if descriptor.read_only:
            print("    Read only: true")
        if descriptor.dynamic_typing:
            print("    Dynamic typing: true")
        ranges = list(descriptor.floating_point_range) + list(descriptor.integer_range)
        if ranges:
            print("    Min value:", ranges[0].from_value)
            print("    Max value:", ranges[0].to_value)
            if ranges[0].step:
                print("    Step:", ranges[0].step)
        if descriptor.additional_constraints:
            print("    Additional constraints:", descriptor.additional_constraints)
    return 0


def delete(args: argparse.Namespace) -> int:
    from rcl_interfaces.msg import Parameter

    with c.CliNode() as node:
        target = _require_node(node, args)
        results = call_set_parameters(node, target, [Parameter(name=args.parameter_name)])
    result = results[0]
    if result.successful:
        print("Deleted parameter successfully")
        return 0
    print("Deleting parameter failed" + (": " + result.reason if result.reason else ""), file=sys.stderr)
    return 1
