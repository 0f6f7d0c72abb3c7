"""`ros2 node list | info`, with ros2cli's (Jazzy) output."""
from __future__ import annotations

import argparse
import sys
from typing import Any

from . import _common as c

NONUNIQUE_WARNING = ("WARNING: Be aware that there are nodes in the graph that share an exact name, "
                     "which can have unintended side effects.")
INFO_NONUNIQUE_WARNING = ('There are {num_nodes} nodes in the graph with the exact name "{node_name}". '
                          "You are seeing information about only one of them.")


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "node", "Various node related sub-commands")

    p = c.add_verb(verbs, "list", "Output a list of available nodes", list_nodes, spin_time=True)
    p.add_argument("-a", "--all", action="store_true", help="Display all nodes even hidden ones")
    p.add_argument("-c", "--count-nodes", action="store_true", help="Only display the number of nodes discovered")

    p = c.add_verb(verbs, "info", "Output information about a node", info, spin_time=True)
    p.add_argument("node_name", help="Node name to request information")
    p.add_argument("--include-hidden", action="store_true", help="Display hidden topics, services, and actions as well")


def list_nodes(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        names = c.list_graph(args, lambda: sorted(c.node_names(node, include_hidden=args.all)))
    if args.count_nodes:
        print(len(names))
    elif names:
        if len(set(names)) != len(names):
            print(NONUNIQUE_WARNING, file=sys.stderr)
        print(*names, sep="\n")
    return 0


def _print_names_and_types(names_and_types: list[tuple[str, list[str]]]) -> None:
    # ros2cli prints an empty line for an empty section (print(*[], sep='\n'))
    print(*["    " + name + ": " + ", ".join(types) for name, types in names_and_types], sep="\n")


def info(args: argparse.Namespace) -> int | str:
    from rclpy.action import graph as action_graph

    target = c.absolute_node_name(args.node_name)
    with c.CliNode() as node:
        c.wait_for_node(node, target, c.lookup_timeout(args))
        count = c.node_names(node, include_hidden=True).count(target)
        if count == 0:
            return "Unable to find node '" + args.node_name + "'"
        if count > 1:
            print(INFO_NONUNIQUE_WARNING.format(num_nodes=count, node_name=target), file=sys.stderr)
        name, namespace = c.split_node_name(target)

        def visible(entries: list[tuple[str, list[str]]]) -> list[tuple[str, list[str]]]:
            return [(n, list(t)) for n, t in entries if args.include_hidden or not c.is_hidden_name(n)]

        print(target)
        print("  Subscribers:")
        _print_names_and_types(visible(node.get_subscriber_names_and_types_by_node(name, namespace)))
        print("  Publishers:")
        _print_names_and_types(visible(node.get_publisher_names_and_types_by_node(name, namespace)))
        print("  Service Servers:")
        _print_names_and_types(visible(node.get_service_names_and_types_by_node(name, namespace)))
        print("  Service Clients:")
        _print_names_and_types(visible(node.get_client_names_and_types_by_node(name, namespace)))
        print("  Action Servers:")
        _print_names_and_types(visible(action_graph.get_action_server_names_and_types_by_node(node, name, namespace)))
        print("  Action Clients:")
        _print_names_and_types(visible(action_graph.get_action_client_names_and_types_by_node(node, name, namespace)))
    return 0
