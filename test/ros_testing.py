"""Real processes for integration tests: own ROS domain, localhost discovery, guaranteed cleanup.

Each pytest session picks a ROS_DOMAIN_ID of its own (from its PID) and limits discovery to
localhost, so parallel runs on one machine never see each other's nodes. Every process is started
in its own process group and killed with it at the end, even when a test fails.
"""
from __future__ import annotations

import contextlib
import os
import threading
import sys
import time
from pathlib import Path
from typing import Any, Iterable, Iterator, Sequence

import numpy as np
import rclpy
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger

# Imported for its effect too: rclpy's ActionClient fixed in place (ros2/rclpy#1123), also for
# the clients that pymoveit2, a library nobody here wrote, builds in the test process.
from interfaces_py.action_client import ActionClient
from interfaces_py.background_spin import BackgroundSpin
from mycobot_planning.paths import config_file
from mycobot_planning.polling import wait_until
from mycobot_planning.ros.bringup import robot as bringup
from mycobot_planning.ros.bringup.process import ManagedProcess
from mycobot_planning.ros.task.task_topics import SOLUTION_QOS, STATISTICS_QOS, task_topics

REPO = Path(__file__).resolve().parent.parent
PYTHON = sys.executable


def ros_env(domain_id: int | None = None) -> dict[str, str]:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain_id if domain_id is not None else session_domain_id())
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    env.pop("ROS_LOCALHOST_ONLY", None)
    return env


_SESSION_DOMAIN: list[int] = []
_DOMAIN_LOCKS = Path("/tmp/mycobot_test_domains")


def session_domain_id() -> int:
    """1..100, stable for this test session (env override: MYCOBOT_TEST_DOMAIN_ID).

    Two test sessions on one machine (a developer's and a fresh-clone run) must not share a
    domain: their nodes would answer each other's clients ("more than one action server"). Each
    session takes the first domain from pid % 100 on whose lock file it gets an exclusive flock,
    held until the process ends (the OS drops it even on a crash)."""
    override = os.environ.get("MYCOBOT_TEST_DOMAIN_ID")
    if override:
        return int(override)
    if not _SESSION_DOMAIN:
        import fcntl

        _DOMAIN_LOCKS.mkdir(parents=True, exist_ok=True)
        start = os.getpid() % 100
        chosen = 1 + start
        for offset in range(100):
            candidate = 1 + (start + offset) % 100
            handle = open(_DOMAIN_LOCKS / f"{candidate}.lock", "w")
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                handle.close()
                continue
            _SESSION_DOMAIN.append(candidate)
            _DOMAIN_LOCK_HANDLES.append(handle)  # kept open: the lock lives as long as the session
            break
        else:
            _SESSION_DOMAIN.append(chosen)  # every domain taken: share one, as before
    return _SESSION_DOMAIN[0]


_DOMAIN_LOCK_HANDLES: list = []


def use_session_domain() -> None:
    """Make this test process (its in-process rclpy clients) join the session's domain."""
    os.environ.update({k: v for k, v in ros_env().items() if k.startswith("ROS_")})


class NodeProcess(ManagedProcess):
    """One node started as `python -m <module> --ros-args ...` (or `python <file.py> ...` when
    ``module`` names a file) on this session's domain, in a process group of its own, output
    captured to a log file: the bring-up's process (mycobot_planning.ros.bringup.process)."""

    def __init__(self, module: str, args: Iterable[str] = (), name: str | None = None, log_dir: Path | None = None):
        name = name or (Path(module).stem if module.endswith(".py") else module.rsplit(".", 1)[-1])
        super().__init__(name, module, list(args), _log_dir(log_dir) / f"{name}-{os.getpid()}-{time.monotonic_ns()}.log")
        self.start(ros_env(), REPO)

    def stop(self, timeout: float = 5.0) -> int | None:
        """SIGINT to its group, SIGKILL after ``timeout`` s; its exit code."""
        super().stop(grace=timeout)
        return self.proc.returncode if self.proc is not None else None


def _log_dir(log_dir: Path | None = None) -> Path:
    return log_dir or Path(os.environ.get("MYCOBOT_TEST_LOG_DIR", "/tmp/mycobot_test_logs"))


def pymoveit2_joints(moveit2: Any, names: Sequence[str]) -> np.ndarray:
    """Positions of ``names`` from the newest /joint_states message a pymoveit2 ``MoveIt2``
    receives after this call (asserts one comes within 5 s)."""
    moveit2.reset_new_joint_state_checker()
    assert wait_until(lambda: moveit2.new_joint_state_available, 5.0)
    state = moveit2.joint_state
    index = {n: i for i, n in enumerate(state.name)}
    return np.array([state.position[index[n]] for n in names])


class ProbeNode:
    """An in-test rclpy node on a private context (so several can live in one pytest process),
    spun on a background thread once ``spin_in_background`` is called; what every ROS test's
    probe shares: service clients by name, Trigger calls, parameter sets, and a clean close."""

    def __init__(self, name: str, executor: Any = None) -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(name, context=self.context)
        self.executor = executor(self.context) if executor else SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.lock = threading.Lock()
        self.clients: dict[str, Any] = {}
        self.spinner: BackgroundSpin | None = None

    def collect(self, msg_type: Any, topic: str, qos: Any = 10) -> list[Any]:
        """Subscribe to ``topic``; the returned list receives every message (under ``lock``)."""
        received: list[Any] = []

        def on_message(msg: Any) -> None:
            with self.lock:
                received.append(msg)

        self.node.create_subscription(msg_type, topic, on_message, qos)
        return received

    def listen_to_joint_states(self) -> None:
        """Keep the latest /joint_states message (only that one) for :meth:`joints`."""
        self._joint_state: Any = None

        def keep(msg: Any) -> None:
            with self.lock:
                self._joint_state = msg

        self.node.create_subscription(JointState, "/joint_states", keep, 10)

    def joints(self) -> dict[str, float]:
        """The latest /joint_states as {name: position} (empty before the first one)."""
        with self.lock:
            msg = self._joint_state
        return dict(zip(msg.name, msg.position)) if msg is not None else {}

    def wait_for_move_group(self, timeout: float = 30.0) -> bool:
        """Whether move_group's planning service and its execute_trajectory and move_action
        servers are known to this node within ``timeout``: what a MoveIt client (pymoveit2) needs
        discovered before its first request, or it gives up at once ("not yet available")."""
        from moveit_msgs.action import ExecuteTrajectory, MoveGroup
        from moveit_msgs.srv import GetMotionPlan

        # kept until the node closes: destroying them while the executor spins stalled it
        actions = [ActionClient(self.node, ExecuteTrajectory, "/execute_trajectory"),
                   ActionClient(self.node, MoveGroup, "/move_action")]
        service = self.node.create_client(GetMotionPlan, "/plan_kinematic_path")
        return wait_until(lambda: service.service_is_ready() and all(a.server_is_ready() for a in actions),
                          timeout, period=0.1)

    def spin_in_background(self) -> None:
        self.spinner = BackgroundSpin(self.executor, name=f"{self.node.get_name()} executor")

    def client(self, srv_type: Any, name: str) -> Any:
        with self.lock:
            if name not in self.clients:
                self.clients[name] = self.node.create_client(srv_type, name)
            return self.clients[name]

    def call(self, srv_type: Any, name: str, request: Any, timeout: float = 15.0) -> Any:
        """Call a service (the background spin answers the future); asserts it answered."""
        client = self.client(srv_type, name)
        assert client.wait_for_service(timeout_sec=15.0), f"service {name} not available"
        future = client.call_async(request)
        assert wait_until(future.done, timeout), f"{name} did not answer"
        return future.result()

    def trigger(self, service: str, timeout: float = 90.0) -> Any:
        return self.call(Trigger, service, Trigger.Request(), timeout)

    def set_parameters(self, node: str, params: Iterable[Any]) -> list[Any]:
        """Set rclpy Parameters on ``node`` as `ros2 param set` does; the SetParametersResults."""
        request = SetParameters.Request(parameters=[p.to_parameter_msg() for p in params])
        return list(self.call(SetParameters, f"/{node}/set_parameters", request).results)

    def set_param(self, node: str, param: Any) -> Any:
        return self.set_parameters(node, [param])[0]

    def close(self) -> None:
        if self.spinner is not None:
            self.spinner.stop()
        else:
            self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


class TaskProbe(ProbeNode):
    """A probe that records what task nodes publish on their task topics (JSON text): how many
    messages a topic has had and the latest one. Subclasses subscribe to more before spinning."""

    def __init__(self, name: str, nodes: Iterable[str], description: bool = True) -> None:
        """Record the statistics and solution topics of every node in ``nodes`` (and, with
        ``description``, its description topic)."""
        super().__init__(name)
        self.received: dict[str, list[String]] = {}
        for node in nodes:
            topics = task_topics(node)
            recorded = [(topics.statistics, STATISTICS_QOS), (topics.solution, SOLUTION_QOS)]
            if description:
                recorded.insert(0, (topics.description, STATISTICS_QOS))
            for topic, qos in recorded:
                self.received[topic] = self.collect(String, topic, qos)

    def count(self, topic: str) -> int:
        with self.lock:
            return len(self.received[topic])

    def latest(self, topic: str) -> str:
        with self.lock:
            return self.received[topic][-1].data


@contextlib.contextmanager
def robot_processes(*server_params: str, params_file: bool | Path = False,
                    controllers_file: Path | None = None,
                    extra_nodes: Sequence[bringup.NodeSpec] = ()) -> Iterator[tuple[ManagedProcess, ...]]:
    """mock_controllers and planning_server on this session's domain, brought up by the bring-up
    module (up when ROS discovery shows them and the server has joint states), stopped at exit.

    ``server_params`` are ``name:=value`` overrides; ``params_file`` adds config/planning_server.yaml
    (True) or the given file; ``controllers_file``: a params file for mock_controllers;
    ``extra_nodes``: more nodes started after them (e.g. bringup.hybrid_planning()), their
    processes yielded after the two."""
    use_session_domain()
    args: list[str] = []
    if params_file:
        args += ["--params-file", str(config_file("planning_server.yaml") if params_file is True else params_file)]
    for param in server_params:
        args += ["-p", param]
    nodes = [bringup.mock_controllers(["--ros-args", "--params-file", str(controllers_file)] if controllers_file else []),
             bringup.planning_server(args), *extra_nodes]
    log_dir = _log_dir() / f"robot-{os.getpid()}-{time.monotonic_ns()}"
    with bringup.Robot(nodes, log_dir, env=ros_env(), cwd=REPO) as robot:
        try:
            robot.start(timeout=90.0)
        except bringup.BringupError as exc:
            raise AssertionError(str(exc)) from None
        yield (robot["mock_controllers"], robot["planning_server"], *(robot[spec.name] for spec in extra_nodes))


#: What each process of :func:`perception_stack` prints once it is up, in start order.
PERCEPTION_STACK_READY = {"controllers": "controller_manager ready", "server": "planning_server ready",
                          "camera": "camera_simulator ready", "perception": "perception_server ready"}


def perception_stack() -> dict[str, NodeProcess]:
    """The robot with eyes, started on this session's domain (the caller waits for
    PERCEPTION_STACK_READY and stops them): mock_controllers, planning_server and
    perception_server with their config/ parameters, and a small (320x240) camera_simulator at
    2 Hz."""
    use_session_domain()
    return {
        "controllers": NodeProcess("mycobot_planning.nodes.mock_controllers"),
        "server": NodeProcess("mycobot_planning.nodes.planning_server",
                              ["--ros-args", "--params-file", str(config_file("planning_server.yaml"))]),
        "camera": NodeProcess("mycobot_planning.nodes.camera_simulator",
                              ["--ros-args", "-p", "width:=320", "-p", "height:=240", "-p", "rate:=2.0"]),
        "perception": NodeProcess("mycobot_planning.nodes.perception_server",
                                  ["--ros-args", "--params-file", str(config_file("perception_server.yaml"))]),
    }


def close_stack(opened: Iterable[Any], procs: dict[str, NodeProcess]) -> None:
    """A fixture's clean-up: close what it opened in the test process, in the given order (None:
    never made), then stop its processes, the last started first."""
    for thing in opened:
        if thing is not None:
            thing.close()
    for proc in reversed(list(procs.values())):
        proc.stop()


#: panda_moveit_config's initial positions of the arm ('ready')
PANDA_READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]


def panda_parameters(directory: Path) -> tuple[Path, Path]:
    """Params files of planning_server and mock_controllers for the Panda as panda_moveit_config
    names it (config/panda/, example-robot-data's URDF), as the README describes the bring-up:
    the arm at 'ready', the hand open."""
    import yaml

    from mycobot_planning.paths import example_robot_data_dir

    urdf = (example_robot_data_dir() / "panda_description" / "urdf" / "panda.urdf").read_text()
    srdf = config_file("panda/panda.srdf").read_text()
    server = {"planning_server": {"ros__parameters": {
        "robot_description": urdf, "robot_description_semantic": srdf,
        "joint_limits_file": str(config_file("panda/joint_limits.yaml")),
        "kinematics_file": str(config_file("panda/kinematics.yaml")),
        "controllers_file": str(config_file("panda/controllers.yaml")),
        "goal.group": "panda_arm"}}}
    initial = {f"panda_joint{i + 1}": value for i, value in enumerate(PANDA_READY)} | {"panda_finger_joint1": 0.035}
    controllers = {"controller_manager": {"ros__parameters": {
        "robot_description": urdf, "robot_description_semantic": srdf,
        "controllers_file": str(config_file("panda/controllers.yaml")),
        "joint_limits_file": str(config_file("panda/joint_limits.yaml")),
        "initial_positions": initial}}}
    paths = directory / "panda_server.yaml", directory / "panda_controllers.yaml"
    for path, data in zip(paths, (server, controllers)):
        path.write_text(yaml.safe_dump(data))
    return paths


@contextlib.contextmanager
def panda_processes(directory: Path) -> Iterator[tuple[ManagedProcess, ManagedProcess]]:
    """The Panda bring-up (mock_controllers and planning_server), ready, stopped at exit."""
    server_file, controllers_file = panda_parameters(directory)
    with robot_processes(params_file=server_file, controllers_file=controllers_file) as processes:
        yield processes
