"""`ros2 service list | type | find | call`, with ros2cli's (Jazzy) output."""
from __future__ import annotations

import argparse
import time
from typing import Any

from . import _common as c


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "service", "Various service related sub-commands")

    p = c.add_verb(verbs, "list", "Output a list of available services", list_services, spin_time=True)
    p.add_argument("-t", "--show-types", action="store_true", help="Additionally show the service type")
    p.add_argument("-c", "--count-services", action="store_true", help="Only display the number of services discovered")
    p.add_argument("--include-hidden-services", action="store_true", help="Consider hidden services as well")

    p = c.add_verb(verbs, "type", "Output a service's type", service_type, spin_time=True)
    p.add_argument("service_name", help="Name of the ROS service to get type (e.g. '/talker/list_parameters')")
    p.add_argument("--include-hidden-services", action="store_true", help="Consider hidden services as well")

    p = c.add_verb(verbs, "find", "Output a list of available services of a given type", find, spin_time=True)
    p.add_argument("service_type", help="Name of the ROS service type to filter for (e.g. 'rcl_interfaces/srv/ListParameters')")
    p.add_argument("-c", "--count-services", action="store_true", help="Only display the number of services discovered")
    p.add_argument("--include-hidden-services", action="store_true", help="Consider hidden services as well")

    p = c.add_verb(verbs, "call", "Call a service", call)
    p.add_argument("service_name", help="Name of the ROS service to call to (e.g. '/add_two_ints')")
    p.add_argument("service_type", help="Type of the ROS service (e.g. 'std_srvs/srv/Empty')")
    p.add_argument("values", nargs="?", default="{}",
                   help="Values to fill the service request with in YAML format (e.g. '{a: 1, b: 2}'), "
                        "otherwise the service request will be published with default values")
    p.add_argument("-r", "--rate", metavar="N", type=c.positive_float, help="Repeat the call at a specific rate in Hz")


def _services(node: Any, include_hidden: bool) -> list[tuple[str, list[str]]]:
    return [(name, list(types)) for name, types in node.get_service_names_and_types()
            if include_hidden or not c.is_hidden_name(name)]


def list_services(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        services = c.list_graph(args, lambda: _services(node, args.include_hidden_services))
    if args.count_services:
        print(len(services))
    else:
        for name, types in services:
            print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def service_type(args: argparse.Namespace) -> int:
    """Prints the type; like ros2cli, an unknown service prints nothing and exits 1."""
    with c.CliNode() as node:
        def probe() -> list[str] | None:
            for name, types in node.get_service_names_and_types():
                if name == args.service_name:
                    return types
            return None

        types = c.wait_for(probe, c.lookup_timeout(args))
    if not types:
        return 1
    print(types[0])
    return 0


def find(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        services = c.list_graph(args, lambda: _services(node, args.include_hidden_services))
    matches = [name for name, types in services if args.service_type in types]
    if args.count_services:
        print(len(matches))
    else:
        for name in matches:
            print(name)
    return 0


def call(args: argparse.Namespace) -> int | str:
    import rclpy

    from ._message import get_service, populate_from_yaml

    try:
        srv_class = get_service(args.service_type)
    except (AttributeError, ModuleNotFoundError, ValueError):
        return "The passed service type is invalid"
    request = srv_class.Request()
    error = populate_from_yaml(request, args.values)
    if error:
        return error

    parts = args.service_type.split("/")
    package, name = parts[0], parts[-1]
    with c.CliNode(f"{c.NODE_NAME_PREFIX}_requester_{package}_{name}") as node:
        client = node.create_client(srv_class, args.service_name)
        if not client.service_is_ready():
            print("waiting for service to become available...", flush=True)
            while rclpy.ok() and not c.wait_for_service(client, 1.0):
                pass
        period = 1.0 / args.rate if args.rate else None
        while rclpy.ok():
            print("requester: making request: %r\n" % request, flush=True)
            last_call = time.monotonic()
            future = client.call_async(request)
            c.spin_until_done(node, future)
            if not future.done():
                break
            if future.result() is None:
                return "Exception while calling service: %r" % future.exception()
            print("response:\n%r\n" % future.result(), flush=True)
            if period is None:
                break
            remaining = last_call + period - time.monotonic()
            if remaining > 0:
                time.sleep(remaining)
    return 0
