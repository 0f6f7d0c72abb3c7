"""What every verb shares: the short-lived CLI node, discovery waits, names and QoS options.

ros2cli asks a long-running daemon for the graph. We have no daemon, so each call creates its own
participant and must wait for discovery. DDS discovery is usually done in ~0.2 s, but Fast DDS
sometimes learns about an existing participant only at that participant's next periodic
announcement (every 3 s by default), so:
- a *named* node/topic/service is polled for until it appears, up to `--spin-time` (default
  LOOKUP_TIMEOUT), before the verb reports it missing: present things are found fast, absent
  things cost the full wait;
- *list* verbs have no name to wait for: they poll until the graph has stopped changing
  (LIST_QUIET after at least LIST_MIN, at most LIST_MAX; an empty graph is not "stopped"); with
  `--spin-time T` they spin for exactly T seconds, as ros2cli does without its daemon.
Nodes that announce themselves more often than every 3 s are found faster (see the Fast DDS
`leaseAnnouncement` setting in the test fixture of test_ros2cli.py).
"""
from __future__ import annotations

import argparse
import os
import time
from typing import Any, Callable, TypeVar

T = TypeVar("T")

LOOKUP_TIMEOUT = 4.0
LIST_MIN = 0.5
LIST_QUIET = 0.3
LIST_MAX = 2.0
POLL_PERIOD = 0.02

NODE_NAME_PREFIX = "_ros2cli"


class CliError(Exception):
    """A failure the user must read: printed to stderr as is, exit code 1, no traceback."""


def add_command(subparsers: Any, name: str, help: str,
                when_no_verb: Callable[[argparse.ArgumentParser], int] | None = None) -> Any:
    """`ros2 <name>`, a command of verbs; given no verb it prints its help (or runs
    ``when_no_verb(parser)``), as ros2cli does. Returns where its verbs are added (:func:`add_verb`)."""
    parser = subparsers.add_parser(name, help=help)
    verbs = parser.add_subparsers(title="Commands", dest="verb",
                                  metavar=f"Call `ros2 {name} <command> -h` for more detailed usage.")
    if when_no_verb is None:
        parser.set_defaults(func=lambda args: parser.print_help() or 0)
    else:
        parser.set_defaults(func=lambda args: when_no_verb(parser))
    return verbs


def add_verb(verbs: Any, name: str, help: str, func: Callable[[argparse.Namespace], Any],
             spin_time: bool = False) -> argparse.ArgumentParser:
    """The parser of verb ``name`` of a command, run by ``func``; ``spin_time``: it reads the
    ROS graph, so it takes --spin-time (and ros2cli's ignored daemon options) first."""
    parser = verbs.add_parser(name, help=help)
    if spin_time:
        add_spin_time_argument(parser)
    parser.set_defaults(func=func)
    return parser


def add_spin_time_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--spin-time", type=positive_float, default=None, metavar="SECONDS",
        help="Spin time in seconds to wait for discovery (default: a named node, topic or service is "
             "waited for up to %.0f s; lists wait until the graph is quiet, at most %.0f s)"
        % (LOOKUP_TIMEOUT, LIST_MAX),
    )
    # ros2cli's daemon options are accepted and ignored (there is no daemon here)
    parser.add_argument("--no-daemon", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--use-sim-time", action="store_true", help=argparse.SUPPRESS)


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if value <= 0:
        raise argparse.ArgumentTypeError("value must be positive")
    return value


def nonnegative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError("value must be non-negative integer")
    return value


def lookup_timeout(args: argparse.Namespace) -> float:
    return getattr(args, "spin_time", None) or LOOKUP_TIMEOUT


def list_graph(args: argparse.Namespace, snapshot: Callable[[], T]) -> T:
    """A list verb's view of the graph: `--spin-time` exactly if given, else until settled."""
    spin_time = getattr(args, "spin_time", None)
    if spin_time:
        time.sleep(spin_time)
        return snapshot()
    return settled(snapshot, LIST_MAX)


class CliNode:
    """rclpy.init + one hidden node for the duration of a verb, always torn down."""

    def __init__(self, name: str | None = None) -> None:
        self._name = name or f"{NODE_NAME_PREFIX}_{os.getpid()}"
        self.node: Any = None

    def __enter__(self) -> Any:
        import rclpy

        rclpy.init(args=[])
        self.node = rclpy.create_node(self._name, enable_rosout=False, start_parameter_services=False)
        return self.node

    def __exit__(self, *exc: Any) -> None:
        import rclpy

        try:
            if self.node is not None:
                self.node.destroy_node()
        except Exception:  # the context may already be shut down by a signal
            pass
        finally:
            rclpy.try_shutdown()


def wait_for_service(client: Any, timeout: float) -> bool:
    """rclpy's Client.wait_for_service polls every 0.25 s; poll faster (each CLI call pays it)."""
    return bool(wait_for(lambda: client.service_is_ready() or not client.context.ok(), timeout)) \
        and client.service_is_ready()


def spin_until_done(node: Any, future: Any, timeout_sec: float | None = None) -> None:
    import rclpy

    rclpy.spin_until_future_complete(node, future, timeout_sec=timeout_sec)


def wait_for(probe: Callable[[], T | None], timeout: float) -> T | None:
    """Poll `probe` until it returns something truthy or `timeout` passes (graph queries need no
    spinning: the middleware updates its graph cache in its own threads)."""
    deadline = time.monotonic() + timeout
    while True:
        result = probe()
        if result:
            return result
        if time.monotonic() >= deadline:
            return result
        time.sleep(POLL_PERIOD)


def settled(snapshot: Callable[[], T], max_time: float) -> T:
    """The graph snapshot once it has been quiet for LIST_QUIET (after LIST_MIN), or at max_time.

    An empty snapshot does not count as quiet: on a busy machine discovery can take longer than
    LIST_MIN, and "nothing there" is then the wrong answer (a node started a moment ago)."""
    start = time.monotonic()
    last = snapshot()
    last_change = start
    while True:
        now = time.monotonic()
        if now - start >= max_time:
            return last
        if last and now - start >= min(LIST_MIN, max_time) and now - last_change >= LIST_QUIET:
            return last
        time.sleep(0.05)
        current = snapshot()
        if current != last:
            last = current
            last_change = time.monotonic()


# ---------------------------------------------------------------------------------------------
# Names


def absolute_node_name(name: str | None) -> str | None:
    if not name:
        return name
    return name if name.startswith("/") else "/" + name


def split_node_name(full_name: str) -> tuple[str, str]:
    """'/ns/name' -> ('name', '/ns'); 'name' -> ('name', '/')."""
    full_name = absolute_node_name(full_name) or "/"
    namespace, _, name = full_name.rpartition("/")
    return name, namespace or "/"


def full_node_name(name: str, namespace: str) -> str:
    return namespace.rstrip("/") + "/" + name


def is_hidden_name(name: str) -> bool:
    """ROS convention: any token of the name starting with '_' hides it."""
    return any(token.startswith("_") for token in name.split("/") if token)


def node_names(node: Any, include_hidden: bool = False) -> list[str]:
    names = [full_node_name(n, ns) for n, ns in node.get_node_names_and_namespaces()]
    return [n for n in names if include_hidden or not is_hidden_name(n)]


def wait_for_node(node: Any, name: str, timeout: float) -> bool:
    """True once the node (hidden or not) is in the graph, False after `timeout`."""
    target = absolute_node_name(name)
    return bool(wait_for(lambda: target in node_names(node, include_hidden=True), timeout))


def expand_topic(node: Any, name: str) -> str:
    """A user's topic name as the graph lists it (relative names resolve against '/')."""
    from rclpy.expand_topic_name import expand_topic_name
    from rclpy.validate_full_topic_name import validate_full_topic_name

    try:
        expanded = expand_topic_name(name, node.get_name(), node.get_namespace())
        validate_full_topic_name(expanded)
    except Exception as exc:  # rclpy raises several exception types for invalid names
        raise CliError(str(exc)) from None
    return expanded


# ---------------------------------------------------------------------------------------------
# QoS options (same names and choices as ros2cli; rclpy.qos is imported only when used)

QOS_PROFILES = ["unknown", "default", "system_default", "sensor_data", "services_default", "parameters",
                "parameter_events", "action_status_default", "best_available"]
QOS_RELIABILITY = ["system_default", "reliable", "best_effort", "unknown", "best_available"]
QOS_DURABILITY = ["system_default", "transient_local", "volatile", "unknown", "best_available"]
QOS_HISTORY = ["system_default", "keep_last", "keep_all", "unknown"]
QOS_LIVELINESS = ["system_default", "automatic", "manual_by_topic", "unknown", "best_available"]


def add_qos_arguments(parser: argparse.ArgumentParser, entity: str, default_profile: str | None) -> None:
    """`default_profile` None: the verb's own default (ros2 topic pub: reliable, transient local, depth 1)."""
    parser.add_argument(
        "--qos-profile", choices=QOS_PROFILES, default=default_profile,
        help=f"Quality of service preset profile to {entity} with"
             + (f" (default: {default_profile})" if default_profile else ""))
    parser.add_argument(
        "--qos-depth", metavar="N", type=int, default=None,
        help=f"Queue size setting to {entity} with (overrides depth value of --qos-profile option)")
    parser.add_argument(
        "--qos-history", choices=QOS_HISTORY, default=None,
        help=f"History of samples setting to {entity} with (overrides history value of --qos-profile option)")
    parser.add_argument(
        "--qos-reliability", choices=QOS_RELIABILITY, default=None,
        help=f"Quality of service reliability setting to {entity} with "
             "(overrides reliability value of --qos-profile option)")
    parser.add_argument(
        "--qos-durability", choices=QOS_DURABILITY, default=None,
        help=f"Quality of service durability setting to {entity} with "
             "(overrides durability value of --qos-profile option)")
    parser.add_argument(
        "--qos-liveliness", choices=QOS_LIVELINESS, default=None,
        help=f"Quality of service liveliness setting to {entity} with "
             "(overrides liveliness value of --qos-profile option)")
    parser.add_argument(
        "--qos-liveliness-lease-duration-seconds", type=float, default=None, metavar="N",
        help=f"Quality of service liveliness lease duration in seconds to {entity} with "
             "(overrides liveliness lease duration value of --qos-profile option)")


def qos_overrides_given(args: argparse.Namespace) -> bool:
    return any(getattr(args, key) is not None for key in (
        "qos_depth", "qos_history", "qos_reliability", "qos_durability", "qos_liveliness",
        "qos_liveliness_lease_duration_seconds"))


def qos_profile_from_args(args: argparse.Namespace, profile: Any = None) -> Any:
    """The preset named by --qos-profile (or `profile`) with the individual overrides applied."""
    import copy

    from rclpy.duration import Duration
    from rclpy.qos import (DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSPresetProfiles,
                           ReliabilityPolicy)

    qos = copy.copy(profile) if profile is not None else copy.copy(
        QoSPresetProfiles.get_from_short_key(args.qos_profile))
    if args.qos_reliability is not None:
        qos.reliability = ReliabilityPolicy.get_from_short_key(args.qos_reliability)
    if args.qos_durability is not None:
        qos.durability = DurabilityPolicy.get_from_short_key(args.qos_durability)
    if args.qos_history is not None:
        qos.history = HistoryPolicy.get_from_short_key(args.qos_history)
    if args.qos_depth is not None and args.qos_depth >= 0:
        qos.depth = args.qos_depth
    if args.qos_liveliness is not None:
        qos.liveliness = LivelinessPolicy.get_from_short_key(args.qos_liveliness)
    if args.qos_liveliness_lease_duration_seconds is not None:
        qos.liveliness_lease_duration = Duration(seconds=args.qos_liveliness_lease_duration_seconds)
    return qos
