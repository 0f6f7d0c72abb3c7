"""`ros2 action list | info | type | send_goal`, with ros2cli's (Jazzy) output."""
from __future__ import annotations

import argparse
from typing import Any

from . import _common as c

STATUS_NAMES = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED", 5: "CANCELED",
                6: "ABORTED"}


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "action", "Various action related sub-commands")

    p = c.add_verb(verbs, "list", "Output a list of action names", list_actions, spin_time=True)
    p.add_argument("-t", "--show-types", action="store_true", help="Additionally show the action type")
    p.add_argument("-c", "--count-actions", action="store_true", help="Only display the number of actions discovered")

    p = c.add_verb(verbs, "info", "Print information about an action", info, spin_time=True)
    p.add_argument("action_name", help="Name of the ROS action to get info (e.g. '/fibonacci')")
    p.add_argument("-t", "--show-types", action="store_true", help="Additionally show the action type")
    p.add_argument("-c", "--count", action="store_true", help="Only display the number of action clients and servers")

    p = c.add_verb(verbs, "type", "Print a action's type", action_type, spin_time=True)
    p.add_argument("action_name", help="Name of the ROS action to get type (e.g. '/fibonacci')")

    p = c.add_verb(verbs, "send_goal", "Send an action goal", send_goal)
    p.add_argument("action_name", help="Name of the ROS action (e.g. '/fibonacci')")
    p.add_argument("action_type", help="Type of the ROS action (e.g. 'example_interfaces/action/Fibonacci')")
    p.add_argument("goal", nargs="?", default="{}",
                   help="Goal request values in YAML format (e.g. '{order: 10}')")
    p.add_argument("-f", "--feedback", action="store_true", help="Echo feedback messages for the goal")


def _actions(node: Any) -> list[tuple[str, list[str]]]:
    from rclpy.action import get_action_names_and_types

    return sorted((name, list(types)) for name, types in get_action_names_and_types(node))


def list_actions(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        actions = c.list_graph(args, lambda: _actions(node))
    if args.count_actions:
        print(len(actions))
        return 0
    for name, types in actions:
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def _endpoints(node: Any, action_name: str) -> tuple[list[tuple[str, list[str]]], list[tuple[str, list[str]]]]:
    """(clients, servers) of an action: (node name, types) of each node that has one."""
    from rclpy.action.graph import (
        get_action_client_names_and_types_by_node,
        get_action_server_names_and_types_by_node,
    )

    clients, servers = [], []
    for name, namespace in node.get_node_names_and_namespaces():
        full = c.full_node_name(name, namespace)
        if c.is_hidden_name(full):
            continue
        for getter, out in ((get_action_client_names_and_types_by_node, clients),
                            (get_action_server_names_and_types_by_node, servers)):
            try:
                entries = getter(node, name, namespace)
            except Exception:  # the node left the graph meanwhile
                continue
            for action, types in entries:
                if action == action_name:
                    out.append((full, list(types)))
    return clients, servers


def info(args: argparse.Namespace) -> int | str:
    with c.CliNode() as node:
        known = c.wait_for(lambda: dict(_actions(node)).get(args.action_name), c.lookup_timeout(args))

        def probe() -> tuple[list, list] | None:
            found = _endpoints(node, args.action_name)
            return found if found[1] else None

        # A new node learns the other nodes' endpoints a little after their names: wait for a
        # server (an action nearly always has one), then for the lists to settle.
        clients, servers = [], []
        if known:
            c.wait_for(probe, c.lookup_timeout(args))
            clients, servers = c.settled(lambda: _endpoints(node, args.action_name), c.LIST_MAX)
    if known is None and not clients and not servers:
        return f"The action '{args.action_name}' is not available"
    print(f"Action: {args.action_name}")
    for label, entries in (("Action clients", clients), ("Action servers", servers)):
        print(f"{label}: {len(entries)}")
        if args.count:
            continue
        for full, types in entries:
            print(f"    {full} [{', '.join(types)}]" if args.show_types else f"    {full}")
    return 0


def action_type(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        types = c.wait_for(lambda: dict(_actions(node)).get(args.action_name), c.lookup_timeout(args))
    if not types:
        return 1
    for t in types:
        print(t)
    return 0


def _yaml(msg: Any) -> str:
    from ._message import message_to_yaml

    return message_to_yaml(msg)


def send_goal(args: argparse.Namespace) -> int | str:
    import rclpy
    from interfaces_py.action_client import ActionClient

    from ._message import get_interface, populate_from_yaml

    try:
        action_class = get_interface(args.action_type if args.action_type.count('/') == 2 else
                                     args.action_type.replace('/', '/action/', 1))
        goal = action_class.Goal()
    except (AttributeError, ModuleNotFoundError, ValueError):
        return "The passed action type is invalid"
    error = populate_from_yaml(goal, args.goal)
    if error:
        return error
    package, name = args.action_type.split("/")[0], args.action_type.split("/")[-1]
    with c.CliNode(f"{c.NODE_NAME_PREFIX}_send_goal_{package}_{name}") as node:
        client = ActionClient(node, action_class, args.action_name)
        try:
            print("Waiting for an action server to become available...", flush=True)
            while rclpy.ok() and not client.wait_for_server(timeout_sec=1.0):
                pass
            print("Sending goal:\n     " + _yaml(goal).rstrip().replace("\n", "\n     ") + "\n", flush=True)

            def on_feedback(message: Any) -> None:
                print("Feedback:\n    " + _yaml(message.feedback).rstrip().replace("\n", "\n    ") + "\n", flush=True)

            future = client.send_goal_async(goal, feedback_callback=on_feedback if args.feedback else None)
            c.spin_until_done(node, future)
            handle = future.result()
            if handle is None:
                return f"Exception while sending goal: {future.exception()!r}"
            if not handle.accepted:
                print("Goal was rejected.")
                return 0
            import uuid

            print(f"Goal accepted with ID: {uuid.UUID(bytes=bytes(handle.goal_id.uuid)).hex}\n", flush=True)
            result_future = handle.get_result_async()
            try:
                c.spin_until_done(node, result_future)
            except KeyboardInterrupt:
                cancel = handle.cancel_goal_async()
                c.spin_until_done(node, cancel, 5.0)
                raise
            response = result_future.result()
            if response is None:
                return f"Exception while getting result: {result_future.exception()!r}"
            print("Result:\n    " + _yaml(response.result).rstrip().replace("\n", "\n    ") + "\n")
            print(f"Goal finished with status: {STATUS_NAMES.get(response.status, response.status)}")
        finally:
            client.destroy()
    return 0
