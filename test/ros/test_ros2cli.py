"""Our `ros2` command (mycobot_planning.ros2cli) against a real node process.

One fixture node (test/ros2cli_fixture_node.py) serves the module: it publishes, subscribes,
serves std_srvs services and declares validated parameters through node_runtime. Every verb
runs as the user runs it, as its own process, and every call checks that no Python traceback
ever reaches the user. The fixture announces itself every 0.25 s (a Fast DDS profile) so that
the list verbs, which cannot wait for a name, see it within their discovery window.

Message conversion helpers (the rosidl_runtime_py stand-in) are also tested in-process.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import yaml

from ros_testing import PYTHON, REPO, ros_env, use_session_domain, wait_until

pytest.importorskip("rclpy")

FIXTURE_NODE = "/ros2cli_fixture"
STARTUP = 30.0
CALL_TIMEOUT = 60.0
FAST_ANNOUNCEMENTS = """<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <participant profile_name="fast_announcements" is_default_profile="true">
    <rtps><builtin><discovery_config>
      <leaseAnnouncement><sec>0</sec><nanosec>250000000</nanosec></leaseAnnouncement>
    </discovery_config></builtin></rtps>
  </participant>
</profiles>
"""


def ros2(*args: str, env: dict[str, str] | None = None, timeout: float = CALL_TIMEOUT) -> subprocess.CompletedProcess:
    """Run `ros2 <args>` as a user would; never a traceback, whatever the outcome."""
    result = subprocess.run(
        [PYTHON, "-m", "mycobot_planning.ros2cli", *args],
        cwd=REPO, env=env or ros_env(), capture_output=True, text=True, timeout=timeout,
    )
    assert "Traceback" not in result.stderr + result.stdout, result.stderr
    return result


def ros2_together(*calls: tuple[str, ...]) -> list[subprocess.CompletedProcess]:
    """Independent `ros2` calls side by side (each call starts its own process and participant)."""
    with ThreadPoolExecutor(max_workers=6) as pool:
        return list(pool.map(lambda args: ros2(*args), calls))


class Fixture:
    def __init__(self, log_dir: Path) -> None:
        profile = log_dir / "fast_announcements.xml"
        profile.write_text(FAST_ANNOUNCEMENTS)
        env = ros_env()
        env["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(profile)
        self.log_path = log_dir / "ros2cli_fixture.log"
        self._log = open(self.log_path, "w")
        self.proc = subprocess.Popen(
            [PYTHON, str(REPO / "test" / "ros2cli_fixture_node.py")],
            cwd=REPO, env=env, stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True,
        )

    def output(self) -> str:
        self._log.flush()
        return self.log_path.read_text(errors="replace")

    def stop(self) -> None:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                self.proc.wait(10)
        self._log.close()


@pytest.fixture(scope="module")
def fixture_node(tmp_path_factory: pytest.TempPathFactory):
    use_session_domain()
    node = Fixture(tmp_path_factory.mktemp("ros2cli"))
    try:
        assert wait_until(lambda: "fixture ready" in node.output() or node.proc.poll() is not None, STARTUP), \
            node.output()
        assert node.proc.poll() is None, node.output()
        yield node
    finally:
        node.stop()


# ---------------------------------------------------------------------------------------------
# topic


def test_list_verbs_show_the_fixture(fixture_node):
    spin = ("--spin-time", "2")  # lists cannot wait for a name: give discovery a fixed window
    topics, services, nodes, hidden, parameters = ros2_together(
        ("topic", "list", "-t", *spin), ("service", "list", "-t", *spin), ("node", "list", *spin),
        ("node", "list", "--all", *spin), ("param", "list", *spin))
    for result in (topics, services, nodes, hidden, parameters):
        assert result.returncode == 0, result.stderr

    lines = topics.stdout.splitlines()
    assert "/fixture/chatter [std_msgs/msg/String]" in lines
    assert "/fixture/command [std_msgs/msg/String]" in lines
    assert "/fixture/trajectory [trajectory_msgs/msg/JointTrajectory]" in lines
    assert lines == sorted(lines)

    lines = services.stdout.splitlines()
    assert "/fixture/trigger [std_srvs/srv/Trigger]" in lines
    assert "/fixture/set_flag [std_srvs/srv/SetBool]" in lines
    assert "/ros2cli_fixture/set_parameters [rcl_interfaces/srv/SetParameters]" in lines
    assert not any(line.startswith("/_") for line in lines)  # hidden services (our CLI's) are not listed

    assert FIXTURE_NODE in nodes.stdout.splitlines()
    assert not any(line.startswith("/_") for line in nodes.stdout.splitlines())
    assert any(line.startswith("/_ros2cli_") for line in hidden.stdout.splitlines())  # --all: itself too

    lines = parameters.stdout.splitlines()
    assert f"{FIXTURE_NODE}:" in lines
    assert "  gain" in lines[lines.index(f"{FIXTURE_NODE}:"):]


def test_topic_echo_once_prints_one_yaml_message_and_exits(fixture_node):
    result = ros2("topic", "echo", "/fixture/chatter", "--once", "--timeout", "20")
    assert result.returncode == 0, result.stderr
    assert re.fullmatch(r"data: hello \d+\n---\n", result.stdout), result.stdout


def test_topic_echo_receives_latched_trajectory_as_yaml(fixture_node):
    result = ros2("topic", "echo", "/fixture/trajectory", "trajectory_msgs/msg/JointTrajectory", "--once", "--timeout", "20")
    assert result.returncode == 0, result.stderr
    document, rest = result.stdout.split("---\n")
    assert rest == ""
    message = yaml.safe_load(document)
    assert list(message) == ["header", "joint_names", "points"]  # .msg field order
    assert message["joint_names"] == ["joint1", "joint2"]
    assert [p["positions"] for p in message["points"]] == [[0.0, 0.5], [0.25, 1.0]]
    assert message["points"][0]["time_from_start"] == {"sec": 0, "nanosec": 0}

    field = ros2("topic", "echo", "/fixture/trajectory", "--once", "--field", "joint_names")
    assert field.stdout == "['joint1', 'joint2']\n---\n"


def test_topic_pub_once_reaches_the_subscriber(fixture_node):
    result = ros2("topic", "pub", "--once", "/fixture/command", "std_msgs/msg/String", "{data: hi from ros2}")
    assert result.returncode == 0, result.stderr
    assert "publisher: beginning loop\n" in result.stdout
    assert "publishing #1: std_msgs.msg.String(data='hi from ros2')\n" in result.stdout
    assert wait_until(lambda: "heard: hi from ros2" in fixture_node.output(), 10.0), fixture_node.output()


def test_topic_hz_prints_rate_reports_until_interrupted(fixture_node):
    proc = subprocess.Popen([PYTHON, "-m", "mycobot_planning.ros2cli", "topic", "hz", "/fixture/chatter"],
                            cwd=REPO, env=ros_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        first = proc.stdout.readline()  # blocks until the first report (about 1 s of messages)
        second = proc.stdout.readline()
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=10)
    assert re.fullmatch(r"average rate: \d+\.\d{3}\n", first), first
    assert re.fullmatch(r"\tmin: \d+\.\d{3}s max: \d+\.\d{3}s std dev: \d+\.\d{5}s window: \d+\n", second), second
    assert float(first.split()[2]) > 0
    assert proc.returncode == 0 and "Traceback" not in err, err


def test_topic_info_counts_and_verbose_endpoints(fixture_node):
    result = ros2("topic", "info", "/fixture/chatter")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[:2] == ["Type: std_msgs/msg/String", "Publisher count: 1"]
    assert lines[2].startswith("Subscription count: ")

    verbose = ros2("topic", "info", "-v", "/fixture/trajectory")
    assert verbose.returncode == 0, verbose.stderr
    assert verbose.stdout.startswith("Type: trajectory_msgs/msg/JointTrajectory\n\nPublisher count: 1\n\n")
    assert "Node name: ros2cli_fixture\nNode namespace: /\n" in verbose.stdout
    assert "Endpoint type: PUBLISHER" in verbose.stdout
    assert "  Durability: TRANSIENT_LOCAL" in verbose.stdout


# ---------------------------------------------------------------------------------------------
# param


def test_param_list_and_get(fixture_node):
    listing, typed, planner, joints, attempts, execute = ros2_together(
        ("param", "list", FIXTURE_NODE),
        ("param", "list", "--param-type", "ros2cli_fixture"),  # relative node name works too
        ("param", "get", FIXTURE_NODE, "planner_id"),
        ("param", "get", FIXTURE_NODE, "joint_names"),
        ("param", "get", FIXTURE_NODE, "attempts"),
        ("param", "get", FIXTURE_NODE, "execute", "--hide-type"),
    )
    assert listing.returncode == 0, listing.stderr
    names = [line.strip() for line in listing.stdout.splitlines()]
    assert {"gain", "execute", "planner_id", "joint_names", "attempts", "use_sim_time"} <= set(names)
    assert names == sorted(names)
    assert all(line.startswith("  ") for line in listing.stdout.splitlines())
    assert "  joint_names (type: string array)" in typed.stdout.splitlines()
    assert planner.stdout == "String value is: RRTConnectkConfigDefault\n"
    assert joints.stdout == "String values are: ['joint1', 'joint2']\n"
    assert attempts.stdout == "Integer value is: 3\n"
    assert execute.stdout == "False\n"


def test_param_set_accepted_then_refused_with_the_nodes_reason(fixture_node):
    accepted = ros2("param", "set", FIXTURE_NODE, "gain", "2.5")
    assert (accepted.returncode, accepted.stdout) == (0, "Set parameter successful\n")

    out_of_range, empty, wrong_type, toggled = ros2_together(
        ("param", "set", FIXTURE_NODE, "gain", "20.0"),
        ("param", "set", FIXTURE_NODE, "planner_id", "''"),
        ("param", "set", FIXTURE_NODE, "gain", "fast"),
        ("param", "set", FIXTURE_NODE, "execute", "true"),
    )
    assert out_of_range.returncode == 0  # as ros2cli: reported on stderr, exit 0
    assert out_of_range.stderr.startswith("Setting parameter failed: ")
    assert "10.0" in out_of_range.stderr  # the range is named
    assert empty.returncode == 0
    assert "Setting parameter failed: planner_id must not be empty" in empty.stderr
    assert wrong_type.returncode == 0 and wrong_type.stderr.startswith("Setting parameter failed")
    assert toggled.returncode == 0

    gain, planner, execute = ros2_together(
        ("param", "get", FIXTURE_NODE, "gain"),
        ("param", "get", FIXTURE_NODE, "planner_id"),
        ("param", "get", FIXTURE_NODE, "execute"),
    )
    assert gain.stdout == "Double value is: 2.5\n"  # the refused values changed nothing
    assert planner.stdout == "String value is: RRTConnectkConfigDefault\n"
    assert execute.stdout == "Boolean value is: True\n"


def test_param_dump_then_load(fixture_node, tmp_path):
    ros2("param", "set", FIXTURE_NODE, "attempts", "5")
    dump = ros2("param", "dump", FIXTURE_NODE)
    assert dump.returncode == 0, dump.stderr
    assert dump.stdout.startswith("/ros2cli_fixture:\n  ros__parameters:\n")
    parameters = yaml.safe_load(dump.stdout)["/ros2cli_fixture"]["ros__parameters"]
    assert parameters["attempts"] == 5
    assert parameters["joint_names"] == ["joint1", "joint2"]
    assert "    joint_names:\n    - joint1\n    - joint2\n" in dump.stdout  # block style, as ros2cli

    # the dump loads back as it is (read-only parameters with unchanged values are left out)
    parameters["attempts"] = 7
    parameters["planner_id"] = "PRMkConfigDefault"
    good = tmp_path / "good.yaml"
    good.write_text(yaml.dump({"/ros2cli_fixture": {"ros__parameters": parameters}}))
    loaded = ros2("param", "load", FIXTURE_NODE, str(good))
    assert loaded.returncode == 0, loaded.stderr
    assert "Set parameter attempts successful" in loaded.stdout.splitlines()

    bad = tmp_path / "bad.yaml"  # file keys without the leading slash are accepted too
    bad.write_text("ros2cli_fixture:\n  ros__parameters:\n    attempts: 500\n")
    other = tmp_path / "other.yaml"
    other.write_text("other_node:\n  ros__parameters:\n    attempts: 2\n")
    refused, missing = ros2_together(("param", "load", FIXTURE_NODE, str(bad)),
                                     ("param", "load", FIXTURE_NODE, str(other)))
    assert refused.returncode == 0
    assert refused.stderr.startswith("Set parameter attempts failed: ")
    assert missing.returncode == 1
    assert "Param file does not contain parameters for /ros2cli_fixture" in missing.stderr

    attempts, planner = ros2_together(("param", "get", FIXTURE_NODE, "attempts"),
                                      ("param", "get", FIXTURE_NODE, "planner_id"))
    assert attempts.stdout == "Integer value is: 7\n"
    assert planner.stdout == "String value is: PRMkConfigDefault\n"


def test_param_describe_shows_description_and_range(fixture_node):
    result = ros2("param", "describe", FIXTURE_NODE, "gain", "execute")
    assert result.returncode == 0, result.stderr
    assert result.stdout == textwrap.dedent("""\
        Parameter name: gain
          Type: double
          Description: Scaling of the fixture's output
          Constraints:
            Min value: 0.0
            Max value: 10.0
        Parameter name: execute
          Type: boolean
          Description: Execute after planning
          Constraints:
        """)


# ---------------------------------------------------------------------------------------------
# service


def test_service_type(fixture_node):
    result = ros2("service", "type", "/fixture/set_flag")
    assert (result.returncode, result.stdout) == (0, "std_srvs/srv/SetBool\n")


def test_service_call_trigger_and_setbool(fixture_node):
    trigger = ros2("service", "call", "/fixture/trigger", "std_srvs/srv/Trigger")
    assert trigger.returncode == 0, trigger.stderr
    assert "requester: making request: std_srvs.srv.Trigger_Request()\n\nresponse:\n" in trigger.stdout
    assert re.search(r"response:\nstd_srvs\.srv\.Trigger_Response\(success=True, message='triggered with gain [0-9.]+'\)\n\n$",
                     trigger.stdout), trigger.stdout

    flag = ros2("service", "call", "/fixture/set_flag", "std_srvs/srv/SetBool", "{data: true}")
    assert flag.returncode == 0, flag.stderr
    assert "requester: making request: std_srvs.srv.SetBool_Request(data=True)\n" in flag.stdout
    assert flag.stdout.endswith("response:\nstd_srvs.srv.SetBool_Response(success=True, message='flag is True')\n\n")


# ---------------------------------------------------------------------------------------------
# node


def test_node_info_lists_endpoints_by_section(fixture_node):
    info = ros2("node", "info", FIXTURE_NODE)
    assert info.returncode == 0, info.stderr
    text = info.stdout
    headings = ["/ros2cli_fixture", "  Subscribers:", "  Publishers:", "  Service Servers:", "  Service Clients:",
                "  Action Servers:", "  Action Clients:"]
    positions = [text.splitlines().index(h) for h in headings]
    assert positions == sorted(positions)
    assert "  Subscribers:\n    /fixture/command: std_msgs/msg/String\n" in text
    assert "    /fixture/chatter: std_msgs/msg/String\n" in text
    assert "    /fixture/trigger: std_srvs/srv/Trigger\n" in text
    assert "    /ros2cli_fixture/get_parameters: rcl_interfaces/srv/GetParameters\n" in text


# ---------------------------------------------------------------------------------------------
# errors, as ros2cli words them


def test_errors_are_one_line_with_nonzero_exit(fixture_node):
    fast = ["--spin-time", "1"]
    cases = [
        (("param", "get", "/no_such_node", "gain", *fast), "Node not found"),
        (("param", "get", FIXTURE_NODE, "no_such_parameter"), "Parameter not set"),
        (("node", "info", "/no_such_node", *fast), "Unable to find node '/no_such_node'"),
        (("topic", "info", "/no_such_topic", *fast), "Unknown topic '/no_such_topic'"),
        (("topic", "echo", "/no_such_topic", "--once", *fast), "Could not determine the type for the passed topic"),
        (("topic", "echo", "/fixture/chatter", "std_msgs/msg/NoSuchType", "--once"), "The passed message type is invalid"),
        (("topic", "pub", "/x", "no_such_msgs/msg/X", "{}"), "The passed message type is invalid"),
        (("topic", "pub", "--once", "/x", "std_msgs/msg/String", "[1, 2]"),
         "The passed value needs to be a dictionary in YAML format"),
        (("service", "call", "/fixture/trigger", "std_srvs/srv/NoSuch"), "The passed service type is invalid"),
        (("service", "call", "/fixture/set_flag", "std_srvs/srv/SetBool", "{nope: 1}"),
         "Failed to populate field: 'SetBool_Request' object has no attribute 'nope'"),
        (("interface", "show", "std_msgs/msg/NoSuch"), "Could not find the interface"),
        (("interface", "show", "no_such_msgs/msg/X"), "Unknown package 'no_such_msgs'"),
        (("pkg", "prefix", "no_such_package"), "Package not found"),
        (("run", "no_such_package", "x"), "Package 'no_such_package' not found"),
        (("run", "mycobot_planning", "no_such_executable"), "No executable found"),
    ]
    results = ros2_together(*(args for args, _ in cases))
    for (args, message), result in zip(cases, results):
        assert result.returncode == 1, (args, result.stdout, result.stderr)
        assert message in result.stderr, (args, result.stderr)
        assert len(result.stderr.strip().splitlines()) == 1, (args, result.stderr)
    unknown_service = ros2("service", "type", "/no_such_service", *fast)
    assert (unknown_service.returncode, unknown_service.stdout) == (1, "")  # ros2cli prints nothing


# ---------------------------------------------------------------------------------------------
# no ROS graph needed


def test_interface_show_string_is_the_definition_file():
    result = ros2("interface", "show", "std_msgs/msg/String")
    assert result.returncode == 0, result.stderr
    definition = (Path(sys.prefix) / "share" / "std_msgs" / "msg" / "String.msg").read_text()
    assert result.stdout == definition.rstrip() + "\n"


def test_interface_show_expands_nested_types_with_tabs():
    result = ros2("interface", "show", "--no-comments", "trajectory_msgs/msg/JointTrajectory")
    assert result.returncode == 0, result.stderr
    assert result.stdout == textwrap.dedent("""\
        std_msgs/Header header
        \tbuiltin_interfaces/Time stamp
        \t\tint32 sec
        \t\tuint32 nanosec
        \tstring frame_id
        string[] joint_names
        JointTrajectoryPoint[] points
        \tfloat64[] positions
        \tfloat64[] velocities
        \tfloat64[] accelerations
        \tfloat64[] effort
        \tbuiltin_interfaces/Duration time_from_start
        \t\tint32 sec
        \t\tuint32 nanosec
        """)
    with_comments = ros2("interface", "show", "trajectory_msgs/msg/JointTrajectory").stdout
    assert with_comments.startswith("# The header is used to specify the coordinate frame")
    assert "\n\nstring[] joint_names\n" not in with_comments  # the comment block sits above it
    service = ros2("interface", "show", "std_srvs/srv/SetBool").stdout
    assert service.splitlines()[1] == "---"


def test_pkg_executables_and_prefix():
    executables = ros2("pkg", "executables", "mycobot_planning")
    assert executables.returncode == 0, executables.stderr
    assert "mycobot_planning ik_over_table" in executables.stdout.splitlines()
    assert "mycobot_planning ros2" not in executables.stdout.splitlines()  # the CLI is not a node
    prefix = ros2("pkg", "prefix", "mycobot_planning")
    assert (prefix.returncode, prefix.stdout) == (0, f"{sys.prefix}\n")
    assert ros2("pkg", "prefix", "std_msgs").stdout == f"{sys.prefix}\n"


def test_run_passes_ros_args_through_and_returns_the_exit_code(tmp_path):
    index = tmp_path / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "demo_pkg").touch()
    executable = tmp_path / "lib" / "demo_pkg" / "talker"
    executable.parent.mkdir(parents=True)
    executable.write_text('#!/bin/sh\necho "argv: $*"\nexit 3\n')
    executable.chmod(0o755)
    env = ros_env()
    env["AMENT_PREFIX_PATH"] = str(tmp_path)

    listing = ros2("pkg", "executables", "demo_pkg", env=env)
    assert listing.stdout == "demo_pkg talker\n"
    result = ros2("run", "demo_pkg", "talker", "a", "--ros-args", "-p", "gain:=2.0", "--params-file", "p.yaml",
                  env=env)
    assert result.stdout == "argv: a --ros-args -p gain:=2.0 --params-file p.yaml\n"
    assert result.returncode == 3


def test_run_console_script_of_the_pip_installed_package():
    result = ros2("run", "mycobot_planning", "ik_over_table", "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: ik_over_table")


# ---------------------------------------------------------------------------------------------
# the rosidl_runtime_py stand-in, in-process


def test_settled_graph_waits_until_the_snapshot_stops_changing():
    from mycobot_planning.ros2cli._common import settled

    snapshots = iter([[], ["/a"], ["/a", "/b"]])
    last: list[str] = []

    def snapshot() -> list[str]:
        nonlocal last
        last = next(snapshots, last)
        return last

    assert settled(snapshot, max_time=10.0) == ["/a", "/b"]


def test_set_message_fields_fills_nested_messages_and_arrays():
    from trajectory_msgs.msg import JointTrajectory

    from mycobot_planning.ros2cli._message import message_to_ordereddict, message_to_yaml, set_message_fields

    msg = JointTrajectory()
    set_message_fields(msg, yaml.safe_load(
        "{joint_names: [a, b], points: [{positions: [1, 2.5], time_from_start: {sec: 2}}]}"))
    assert list(msg.joint_names) == ["a", "b"]
    assert list(msg.points[0].positions) == [1.0, 2.5]
    assert msg.points[0].time_from_start.sec == 2
    round_trip = JointTrajectory()
    set_message_fields(round_trip, yaml.safe_load(message_to_yaml(msg)))
    assert round_trip == msg
    truncated = message_to_ordereddict(msg, truncate_length=1)
    assert truncated["joint_names"] == ["a", "..."]

    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        set_message_fields(JointTrajectory(), {"nope": 1})
    with pytest.raises(TypeError, match="expected to be a dictionary"):
        set_message_fields(JointTrajectory(), {"header": 5})


def test_set_message_fields_auto_header_returns_stamp_setters():
    from builtin_interfaces.msg import Time
    from geometry_msgs.msg import PoseStamped

    from mycobot_planning.ros2cli._message import set_message_fields

    msg = PoseStamped()
    setters = set_message_fields(msg, {"header": "auto", "pose": {"position": {"x": 1.0}}},
                                 expand_header_auto=True, expand_time_now=True)
    assert len(setters) == 1
    setters[0](Time(sec=12, nanosec=34))
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.pose.position.x) == (12, 34, 1.0)
