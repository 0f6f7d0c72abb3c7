"""`ros2 topic list | info | type | echo | pub | hz`, with ros2cli's (Jazzy) output."""
from __future__ import annotations

import argparse
import math
import threading
import time
from typing import Any

from . import _common as c

DEFAULT_TRUNCATE_LENGTH = 128
DEFAULT_WINDOW_SIZE = 10000
PUBLISHER_WAIT = 2.0  # echo with an explicit type: how long to look for publishers to match QoS


def register(subparsers: Any) -> None:
    verbs = c.add_command(subparsers, "topic", "Various topic related sub-commands", when_no_verb=_usage)

    p = c.add_verb(verbs, "list", "Output a list of available topics", list_topics, spin_time=True)
    p.add_argument("-t", "--show-types", action="store_true", help="Additionally show the topic type")
    p.add_argument("-c", "--count-topics", action="store_true", help="Only display the number of topics discovered")
    p.add_argument("--include-hidden-topics", action="store_true", help="Consider hidden topics as well")
    p.add_argument("-v", "--verbose", action="store_true", help="List full details about each topic")

    p = c.add_verb(verbs, "info", "Print information about a topic", info, spin_time=True)
    p.add_argument("topic_name", help="Name of the ROS topic to get info (e.g. '/chatter')")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="Prints detailed information like the node name, node namespace, topic type, "
                        "GUID and QoS Profile of the publishers and subscribers to this topic")

    p = c.add_verb(verbs, "type", "Print a topic's type", topic_type, spin_time=True)
    p.add_argument("topic_name", help="Name of the ROS topic to get type (e.g. '/chatter')")

    p = c.add_verb(verbs, "echo", "Output messages from a topic", echo, spin_time=True)
    p.add_argument("topic_name", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument("message_type", nargs="?", help="Type of the ROS message (e.g. 'std_msgs/msg/String')")
    c.add_qos_arguments(p, "subscribe", "sensor_data")
    p.add_argument("--csv", action="store_true", help="Output all recursive fields separated by commas (e.g. for plotting)")
    p.add_argument("--field", type=str, default=None,
                   help="Echo a selected field of a message. Use '.' to select sub-fields. For example, to echo "
                        "the position field of a nav_msgs/msg/Odometry message: "
                        "'ros2 topic echo /odom --field pose.pose.position'")
    p.add_argument("--full-length", "-f", action="store_true",
                   help="Output all elements for arrays, bytes, and string with a length > '--truncate-length', "
                        "by default they are truncated after '--truncate-length' elements with '...'")
    p.add_argument("--truncate-length", "-l", type=c.nonnegative_int, default=DEFAULT_TRUNCATE_LENGTH,
                   help="The length to truncate arrays, bytes, and string to (default: %d)" % DEFAULT_TRUNCATE_LENGTH)
    p.add_argument("--no-arr", action="store_true", help="Don't print array fields of messages")
    p.add_argument("--no-str", action="store_true", help="Don't print string fields of messages")
    p.add_argument("--flow-style", action="store_true", help="Print collections in the block style (not available with csv format)")
    p.add_argument("--no-lost-messages", action="store_true", help="Don't report when a message is lost")
    p.add_argument("--filter", dest="filter_expr",
                   help="Python expression to filter messages that are printed. Expression can use Python "
                        "builtins as well as m (the message).")
    p.add_argument("--once", action="store_true", help="Print the first message received and then exit.")
    p.add_argument("--timeout", metavar="N", type=c.positive_float, default=None, help="Set a timeout in seconds for waiting")
    p.add_argument("--include-message-info", "-i", action="store_true", help="Shows the associated message info.")

    p = c.add_verb(verbs, "pub", "Publish a message to a topic", pub)
    p.add_argument("topic_name", help="Name of the ROS topic to publish to (e.g. '/chatter')")
    p.add_argument("message_type", help="Type of the ROS message (e.g. 'std_msgs/String')")
    p.add_argument("values", nargs="?", default="{}",
                   help="Values to fill the message with in YAML format (e.g. 'data: Hello World'), "
                        "otherwise the message will be published with default values")
    p.add_argument("-r", "--rate", metavar="N", type=c.positive_float, default=1.0, help="Publishing rate in Hz (default: 1)")
    p.add_argument("-p", "--print", metavar="N", type=int, default=1, help="Only print every N-th published message (default: 1)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("-1", "--once", action="store_true", help="Publish one message and exit")
    group.add_argument("-t", "--times", type=c.nonnegative_int, default=0, help="Publish this number of times and then exit")
    p.add_argument("-w", "--wait-matching-subscriptions", type=c.nonnegative_int, default=None,
                   help='Wait until finding the specified number of matching subscriptions. '
                        'Defaults to 1 when using "-1"/"--once"/"--times", otherwise defaults to 0.')
    p.add_argument("--max-wait-time-secs", type=c.positive_float, default=None, metavar="N",
                   help="Maximum time to wait for matching subscriptions (default: wait forever)")
    p.add_argument("--keep-alive", metavar="N", type=c.positive_float, default=0.1,
                   help="Keep publishing node alive for N seconds after the last msg (default: 0.1)")
    p.add_argument("-n", "--node-name", help="Name of the created publishing node")
    c.add_qos_arguments(p, "publish", None)

    p = c.add_verb(verbs, "hz", "Print the average publishing rate to screen", hz)
    p.add_argument("topic_name", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument("--window", "-w", dest="window_size", type=c.nonnegative_int, default=DEFAULT_WINDOW_SIZE,
                   metavar="WINDOW",
                   help="window size, in # of messages, for calculating rate (default: %d)" % DEFAULT_WINDOW_SIZE)
    p.add_argument("--filter", dest="filter_expr", default=None, metavar="EXPR",
                   help="only measure messages matching the specified Python expression")
    p.add_argument("--wall-time", dest="use_wtime", default=False, action="store_true",
                   help="calculates rate using wall time which can be helpful when clock is not published during simulation")


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 0


def _topics(node: Any, include_hidden: bool) -> list[tuple[str, list[str]]]:
    return [(name, types) for name, types in node.get_topic_names_and_types()
            if include_hidden or not c.is_hidden_name(name)]


def _find_topic_types(node: Any, topic: str, timeout: float) -> list[str] | None:
    def probe() -> list[str] | None:
        for name, types in node.get_topic_names_and_types():
            if name == topic:
                return list(types)
        return None

    return c.wait_for(probe, timeout)


# ---------------------------------------------------------------------------------------------


def list_topics(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        topics = c.list_graph(args, lambda: _topics(node, args.include_hidden_topics))
        info = [(name, types, node.count_publishers(name), node.count_subscribers(name)) for name, types in topics]
    if args.count_topics:
        print(len(topics))
    elif topics:
        if args.verbose:
            for is_pub in (True, False):
                print("\n" + ("Published" if is_pub else "Subscribed") + " topics:")
                for name, types, pubs, subs in info:
                    count = pubs if is_pub else subs
                    if count:
                        kind = "publisher" if is_pub else "subscriber"
                        print(f" * {name} [{', '.join(types)}] {count} {kind}{'s' if count > 1 else ''}")
            print()
        else:
            for name, types, _, _ in info:
                print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def info(args: argparse.Namespace) -> int | str:
    with c.CliNode() as node:
        topic = c.expand_topic(node, args.topic_name)
        types = _find_topic_types(node, topic, c.lookup_timeout(args))
        if not types:
            return "Unknown topic '%s'" % args.topic_name
        # A topic is first seen through any one endpoint; the counts settle a moment later. A side
        # still at zero may be a participant Fast DDS has not announced yet (it can take up to its
        # 3 s announcement period): wait for it up to the lookup timeout before reporting zero.
        c.settled(lambda: (node.count_publishers(topic), node.count_subscribers(topic)),
                  getattr(args, "spin_time", None) or c.LIST_MAX)
        c.wait_for(lambda: node.count_publishers(topic) and node.count_subscribers(topic),
                   c.lookup_timeout(args))
        if args.verbose:  # endpoints can be known before their node's name is: wait for the names
            c.wait_for(lambda: not any(
                e.node_name == "_NODE_NAME_UNKNOWN_" for e in
                node.get_publishers_info_by_topic(topic) + node.get_subscriptions_info_by_topic(topic)),
                c.lookup_timeout(args))
        line_end = "\n\n" if args.verbose else "\n"
        print("Type: %s" % (types[0] if len(types) == 1 else types), end=line_end)
        print("Publisher count: %d" % node.count_publishers(topic), end=line_end)
        if args.verbose:
            for endpoint in node.get_publishers_info_by_topic(topic):
                print(endpoint, end=line_end)
        print("Subscription count: %d" % node.count_subscribers(topic), end=line_end)
        if args.verbose:
            for endpoint in node.get_subscriptions_info_by_topic(topic):
                print(endpoint, end=line_end)
    return 0


def topic_type(args: argparse.Namespace) -> int:
    with c.CliNode() as node:
        topic = c.expand_topic(node, args.topic_name)
        types = _find_topic_types(node, topic, c.lookup_timeout(args))
    if not types:
        return 1
    for name in types:
        print(name)
    return 0


# ---------------------------------------------------------------------------------------------
# echo


def _message_class(type_name: str | None, node: Any, topic: str, timeout: float) -> Any:
    from ._message import get_message

    if type_name is None:
        types = _find_topic_types(node, topic, timeout)
        if not types:
            raise c.CliError("Could not determine the type for the passed topic")
        if len(types) > 1:
            raise c.CliError("Cannot echo topic '%s', as it contains more than one type: [%s]" % (topic, ", ".join(types)))
        type_name = types[0]
    try:
        return get_message(type_name)
    except (AttributeError, ModuleNotFoundError, ValueError):
        raise c.CliError("The passed message type is invalid") from None


def _offered_by_all(publishers: list[Any], policy: str, strict: Any, lenient: Any, kind: str) -> Any:
    """``strict`` when every publisher offers it for ``policy``, else ``lenient`` (which connects
    to all of them), saying so when only some offer ``strict`` (ros2cli's words)."""
    offering = sum(getattr(p.qos_profile, policy) == strict for p in publishers)
    if offering == len(publishers):
        return strict
    if offering:
        print(f"Some, but not all, publishers are offering {kind}.{strict.name}. Falling back to "
              f"{kind}.{lenient.name} as it will connect to all publishers")
    return lenient


def _choose_echo_qos(node: Any, args: argparse.Namespace, topic: str) -> Any:
    """ros2cli's rule: follow the publishers (reliable / transient_local only if all offer it)."""
    from rclpy.qos import DurabilityPolicy, QoSPresetProfiles, ReliabilityPolicy

    if c.qos_overrides_given(args):
        return c.qos_profile_from_args(args)
    qos = QoSPresetProfiles.get_from_short_key(args.qos_profile)
    publishers = node.get_publishers_info_by_topic(topic)
    if not publishers:
        return qos
    qos.reliability = _offered_by_all(publishers, "reliability", ReliabilityPolicy.RELIABLE,
                                      ReliabilityPolicy.BEST_EFFORT, "QoSReliabilityPolicy")
    qos.durability = _offered_by_all(publishers, "durability", DurabilityPolicy.TRANSIENT_LOCAL,
                                     DurabilityPolicy.VOLATILE, "QoSDurabilityPolicy")
    return qos


def _compile_filter(expr: str | None) -> Any:
    if not expr:
        return None
    try:
        code = compile(expr, "<filter>", "eval")
    except SyntaxError as exc:
        raise c.CliError(f"Invalid filter expression '{expr}': {exc.msg}") from None
    return lambda m: eval(code, {}, {"m": m})  # noqa: S307 - the user's own expression, as in ros2cli


def echo(args: argparse.Namespace) -> int | str:
    import rclpy
    from rclpy.task import Future

    from ._message import message_to_csv, message_to_yaml

    field = None
    if args.field is not None:
        field = [part for part in args.field.split(".") if part]
        if not field:
            return f"Invalid field value '{args.field}'"
    truncate = None if args.full_length else args.truncate_length
    keep = _compile_filter(args.filter_expr)

    with c.CliNode() as node:
        topic = c.expand_topic(node, args.topic_name)
        msg_class = _message_class(args.message_type, node, topic, c.lookup_timeout(args))
        if args.message_type is not None and not c.qos_overrides_given(args):
            # the QoS follows the publishers (a latched topic needs transient local): give discovery
            # a moment to find them, short enough not to miss messages of a topic that starts later
            c.wait_for(lambda: node.count_publishers(topic) > 0, min(c.lookup_timeout(args), PUBLISHER_WAIT))
        qos = _choose_echo_qos(node, args, topic)
        done = Future()
        failure: list[str] = []

        def on_message(msg: Any, message_info: Any = None) -> None:
            if done.done():
                return
            value = msg
            if field is not None:
                for part in field:
                    try:
                        value = getattr(value, part)
                    except AttributeError as exc:
                        failure.append(f"Invalid field '{'.'.join(field)}': {exc}")
                        done.set_result(False)
                        return
            try:
                if keep is not None and not keep(value):
                    return
            except Exception as exc:  # a user's filter that fails on a message
                failure.append(f"Filter expression failed: {exc}")
                done.set_result(False)
                return
            if not hasattr(value, "get_fields_and_field_types"):
                print(value, end="\n---\n", flush=True)
            elif args.csv:
                print(message_to_csv(value, truncate_length=truncate, no_arr=args.no_arr, no_str=args.no_str), flush=True)
            else:
                if args.include_message_info and message_info is not None:
                    import yaml

                    print(yaml.dump(dict(message_info)), end="---\n")
                print(message_to_yaml(value, truncate_length=truncate, no_arr=args.no_arr, no_str=args.no_str,
                                      flow_style=args.flow_style), end="---\n", flush=True)
            if args.once:
                done.set_result(True)

        event_callbacks = None
        if not args.no_lost_messages:
            from rclpy.event_handler import SubscriptionEventCallbacks

            event_callbacks = SubscriptionEventCallbacks(message_lost=_message_lost)
        try:
            node.create_subscription(msg_class, topic, on_message, qos, event_callbacks=event_callbacks)
        except Exception:  # an RMW without the message-lost event
            node.create_subscription(msg_class, topic, on_message, qos)
        if args.timeout is not None:
            node.create_timer(args.timeout, lambda: done.done() or done.set_result(True))
        while rclpy.ok() and not done.done():
            rclpy.spin_once(node, timeout_sec=0.1)
    return failure[0] if failure else 0


def _message_lost(status: Any) -> None:
    print("A message was lost!!!\n\ttotal count change:"
          f"{status.total_count_change}\n\ttotal count: {status.total_count}", end="---\n", flush=True)


# ---------------------------------------------------------------------------------------------
# pub


def pub(args: argparse.Namespace) -> int | str:
    import rclpy
    import yaml
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from ._message import get_message, set_message_fields

    try:
        msg_class = get_message(args.message_type)
    except (AttributeError, ModuleNotFoundError, ValueError):
        return "The passed message type is invalid"
    try:
        values = yaml.safe_load(args.values)
    except yaml.YAMLError as exc:
        return f"The passed value needs to be a dictionary in YAML format: {getattr(exc, 'problem', None) or exc}"
    if not isinstance(values, dict):
        return "The passed value needs to be a dictionary in YAML format"
    msg = msg_class()
    try:
        timestamp_fields = set_message_fields(msg, values, expand_header_auto=True, expand_time_now=True)
    except Exception as exc:
        return "Failed to populate field: {0}".format(exc)

    default = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL, depth=1)
    qos = c.qos_profile_from_args(args, default if args.qos_profile is None else None)
    times = 1 if args.once else args.times
    wait_subs = args.wait_matching_subscriptions if args.wait_matching_subscriptions is not None else int(times != 0)
    period = 1.0 / args.rate

    with c.CliNode(args.node_name) as node:
        topic = c.expand_topic(node, args.topic_name)
        publisher = node.create_publisher(msg_class, topic, qos)
        start = time.monotonic()
        ticks = 0
        while publisher.get_subscription_count() < wait_subs:
            if args.max_wait_time_secs is not None and time.monotonic() - start >= args.max_wait_time_secs:
                return f"Timed out waiting for subscribers: Expected {wait_subs} subcribers but only got " \
                       f"{publisher.get_subscription_count()} subscribers"
            if ticks % 10 == 0:
                print(f"Waiting for at least {wait_subs} matching subscription(s)...", flush=True)
            ticks += 1
            time.sleep(0.1)

        print("publisher: beginning loop", flush=True)
        count = 0

        def publish_once() -> None:
            nonlocal count
            count += 1
            for stamp in timestamp_fields:
                stamp(node.get_clock().now().to_msg())
            if args.print and count % args.print == 0:
                print("publishing #%d: %r\n" % (count, msg), flush=True)
            publisher.publish(msg)

        publish_once()
        if times != 1:
            timer = node.create_timer(period, publish_once)
            while rclpy.ok() and (times == 0 or count < times):
                rclpy.spin_once(node, timeout_sec=0.1)
            node.destroy_timer(timer)
        # give the last message time to reach the wire (and late joiners of a latched topic)
        time.sleep(args.keep_alive)
    return 0


# ---------------------------------------------------------------------------------------------
# hz


class _RateMeter:
    """ros2cli's ROSTopicHz for one topic: inter-arrival times over a window, printed each second."""

    def __init__(self, clock: Any, window_size: int, keep: Any, use_wall_time: bool) -> None:
        self._lock = threading.Lock()
        self._clock = clock
        self._window = window_size
        self._keep = keep
        self._wall = use_wall_time
        self._t0 = -1
        self._tn = 0
        self._last_printed = 0
        self._times: list[int] = []

    def _now(self) -> int:
        if self._wall:
            return time.time_ns()
        return self._clock.now().nanoseconds

    def on_message(self, msg: Any) -> None:
        if self._keep is not None and not self._keep(msg):
            return
        with self._lock:
            now = self._now()
            if now == 0:  # time reset (simulated clock)
                if self._times:
                    print("time has reset, resetting counters")
                    self._times = []
                return
            if self._t0 < 0 or self._t0 > now:
                self._t0 = now
                self._tn = now
                self._times = []
            else:
                self._times.append(now - self._tn)
                self._tn = now
            if len(self._times) > self._window:
                self._times.pop(0)

    def report(self) -> None:
        with self._lock:
            if not self._times:
                return
            if self._last_printed == 0:
                self._last_printed = self._tn
                return
            if self._tn < self._last_printed + 1e9:
                return
            times = list(self._times)
            self._last_printed = self._tn
        n = len(times)
        mean = sum(times) / n
        rate = 1.0 / mean if mean > 0 else 0.0
        std_dev = math.sqrt(sum((x - mean) ** 2 for x in times) / n)
        print("average rate: %.3f\n\tmin: %.3fs max: %.3fs std dev: %.5fs window: %s"
              % (rate * 1e9, min(times) * 1e-9, max(times) * 1e-9, std_dev * 1e-9, n), flush=True)


def hz(args: argparse.Namespace) -> int:
    import rclpy
    from rclpy.qos import qos_profile_sensor_data

    from ._message import get_message

    keep = _compile_filter(args.filter_expr)
    with c.CliNode() as node:
        topic = c.expand_topic(node, args.topic_name)
        types = _find_topic_types(node, topic, c.LOOKUP_TIMEOUT)
        if not types:
            print("WARNING: topic [%s] does not appear to be published yet" % topic, flush=True)
            while rclpy.ok() and not types:
                types = _find_topic_types(node, topic, 1.0)
        try:
            msg_class = get_message(types[0])
        except (AttributeError, ModuleNotFoundError, ValueError):
            raise c.CliError("The passed message type is invalid") from None
        meter = _RateMeter(node.get_clock(), args.window_size, keep, args.use_wtime)
        node.create_subscription(msg_class, topic, meter.on_message, qos_profile_sensor_data)
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.1)
            meter.report()
    return 0
