"""Bring-up without a launch system: start, check and stop a robot's nodes.

A robot is the controllers (the mock's, the MuJoCo twin mujoco_sim, or mycobot_driver on a serial
port or on the emulated arm, mycobot_emulator), robot_state_publisher and the planning_server, plus optional nodes (task
nodes, the task viewer, the camera and perception). Each runs as ``python -m
mycobot_planning.nodes.<name>`` in a process group of its own with its log in one folder; it
counts as up when ROS discovery shows its node, services and actions (and, for the
planning_server, when it answers get_state with joint states received). ``scripts/robot.sh``,
the demos, the test fixtures and the benchmarks all start robots through :class:`Robot`. A run
folder (optional) records the PIDs so that another invocation can report on and stop them.
"""
from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Callable, Mapping, Sequence

from interfaces_py.clients import PlanningSceneInterface, RpcError
from mycobot_planning.ros.bringup.process import ManagedProcess
from mycobot_planning.ros.bringup.readiness import GraphProbe, Readiness, describe

#: The node of each executable of the package that a robot may hold, and what shows it is up.
DEFAULT_CONTROLLER_ACTIONS = ("/arm_controller/follow_joint_trajectory", "/grip_action_controller/gripper_cmd")
PLANNING_SERVER_READY = Readiness(nodes=("/planning_server", "/move_group"),
                                  services=("/plan_kinematic_path", "/get_planning_scene", "/planning_server/get_planning_scene"),
                                  actions=("/execute_trajectory", "/move_action"))


class BringupError(RuntimeError):
    """A robot did not come up (what and why; whatever this start launched is stopped again)."""


@dataclass
class NodeSpec:
    """One process of a robot: its name (log ``<name>.log``, PID file ``<name>.pid``), the module
    it runs, its arguments, what shows it is up, and an optional last check
    (``check(seconds) -> None | problem``) made once discovery shows it."""

    name: str
    args: list[str] = field(default_factory=list)
    ready: Readiness = Readiness()
    module: str = ""
    check: Callable[[float], str | None] | None = None

    def __post_init__(self) -> None:
        self.module = self.module or f"mycobot_planning.nodes.{self.name}"


def planning_server_answers(timeout: float) -> str | None:
    """None when the planning_server answers get_state with joint states received (it can plan
    from the robot's state) within ``timeout`` s, else what is wrong."""
    deadline = time.monotonic() + max(0.5, timeout)
    problem = "the planning_server does not answer requests"
    with PlanningSceneInterface(timeout=5.0) as client:
        if not client.wait_for_server(max(0.1, deadline - time.monotonic())):
            return problem
        while True:
            try:
                if client.call("get_state").get("joint_state_received"):
                    return None
                problem = "it has received no /joint_states yet"
            except RpcError as exc:
                problem = str(exc)
            if time.monotonic() > deadline:
                return f"the planning_server is not ready: {problem}"
            time.sleep(0.1)


def ros_args(args: Sequence[str]) -> list[str]:
    """``args`` behind ``--ros-args`` (added unless they start with it)."""
    args = list(args)
    return args if not args or args[0] == "--ros-args" else ["--ros-args", *args]


def mock_controllers(args: Sequence[str] = ()) -> NodeSpec:
    """The mock controllers (node controller_manager). With arguments (another robot's
    controllers file) only the node and /joint_states are awaited."""
    actions = () if args else DEFAULT_CONTROLLER_ACTIONS
    return NodeSpec("mock_controllers", list(args),
                    Readiness(nodes=("/controller_manager",), topics=("/joint_states",), actions=actions))


def mycobot_driver(port: str, params: Sequence[str] = ()) -> NodeSpec:
    args = ["--ros-args", "-p", f"port:={port}"]
    for p in params:
        args += ["-p", p]
    return NodeSpec("mycobot_driver", args, Readiness(nodes=("/mycobot_driver",), actions=DEFAULT_CONTROLLER_ACTIONS))


#: The simulators ``--sim`` offers: the node that stands in for the controllers.
SIMULATORS = ("mujoco",)


def mujoco_sim(params: Sequence[str] = ()) -> NodeSpec:
    """The MuJoCo twin (node mujoco_sim): the mock's controllers over a physics simulation;
    ``params``: NAME:=VALUE parameters."""
    args = ["--ros-args", *(a for p in params for a in ("-p", p))] if params else []
    return NodeSpec("mujoco_sim", args, Readiness(nodes=("/mujoco_sim",), topics=("/joint_states",),
                                                        actions=DEFAULT_CONTROLLER_ACTIONS))


def mycobot_emulator(link: Path, control: Path) -> NodeSpec:
    """The emulated arm on a pseudo-terminal (no ROS node): up when its port and control socket exist."""
    return NodeSpec("mycobot_emulator", ["--link", str(link), "--control", str(control)],
                    Readiness(paths=(str(link), str(control))), module="mycobot_planning.hardware.emulator")


def robot_state_publisher(args: Sequence[str] = ()) -> NodeSpec:
    return NodeSpec("robot_state_publisher", list(args),
                    Readiness(nodes=("/robot_state_publisher",), topics=("/robot_description",)))


def planning_server(args: Sequence[str] = (), check_joint_states: bool = True) -> NodeSpec:
    return NodeSpec("planning_server", ros_args(args), PLANNING_SERVER_READY,
                    check=planning_server_answers if check_joint_states else None)


def extra_node(name: str, args: Sequence[str] = (), node: str | None = None,
               ready: Readiness | None = None) -> NodeSpec:
    """An optional node of the package (task_viewer, camera_simulator, perception_server, a task
    node): up when its node (default: its name) is discovered."""
    return NodeSpec(name, list(args), ready or Readiness(nodes=(f"/{node or name}",)))


HYBRID_PLANNING_READY = Readiness(
    nodes=("/hybrid_planning_manager", "/global_planner_component", "/local_planner_component"),
    actions=("/run_hybrid_planning", "/global_planning_action", "/local_planning_action"))


def hybrid_planning(args: Sequence[str] = ()) -> NodeSpec:
    """Hybrid planning's manager, global and local planner in one process (after the planning_server)."""
    return NodeSpec("hybrid_planning", ros_args(args), HYBRID_PLANNING_READY)


def robot_nodes(hardware: str = "", run_dir: Path | None = None, server_args: Sequence[str] = (),
                driver_params: Sequence[str] = (), sim: str = "", sim_params: Sequence[str] = ()) -> list[NodeSpec]:
    """The processes of a robot in start order: the mock controllers, or with ``hardware`` (a
    serial port, or "emulated": the emulated arm, its port in ``run_dir``) mycobot_driver, or
    with ``sim`` ("mujoco") the simulator (with ``sim_params``, NAME:=VALUE);
    robot_state_publisher; the planning_server with ``server_args`` (ROS arguments)."""
    nodes: list[NodeSpec] = []
    if sim:
        if hardware:
            raise ValueError("a robot is either simulated (sim) or hardware, not both")
        if sim not in SIMULATORS:
            raise ValueError(f"unknown simulator '{sim}' (known: {', '.join(SIMULATORS)})")
        nodes.append(mujoco_sim(sim_params))
    elif not hardware:
        nodes.append(mock_controllers())
    else:
        port = hardware
        if hardware == "emulated":
            base = Path(run_dir) if run_dir is not None else Path("/tmp")
            port = str(base / "mycobot_port")
            nodes.append(mycobot_emulator(Path(port), base / "mycobot_emulator.sock"))
        nodes.append(mycobot_driver(port, driver_params))
    nodes.append(robot_state_publisher())
    nodes.append(planning_server(server_args))
    return nodes


def ros_environment(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The nodes' environment: ``base`` (default os.environ) with localhost discovery unless set,
    unbuffered output."""
    env = dict(os.environ if base is None else base)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env["PYTHONUNBUFFERED"] = "1"
    return env


class Robot:
    """A set of nodes started, checked and stopped together (see the module docstring).

    ``log_dir``: one ``<name>.log`` per process; ``run_dir`` (optional): ``<name>.pid`` per
    process, so that another Robot on the same folders (another robot.sh call) adopts them;
    ``say``/``warn``: where progress and problems are reported."""

    def __init__(self, nodes: Sequence[NodeSpec], log_dir: Path, run_dir: Path | None = None,
                 env: Mapping[str, str] | None = None, cwd: Path | None = None,
                 say: Callable[[str], None] = lambda text: None, warn: Callable[[str], None] = lambda text: None,
                 fresh_logs: bool = True) -> None:
        self.nodes = list(nodes)
        self.log_dir = Path(log_dir).resolve()
        self.run_dir = Path(run_dir).resolve() if run_dir is not None else None
        self.env = ros_environment(env)
        self.cwd = cwd or Path.cwd()
        self.say, self.warn = say, warn
        self.fresh_logs = fresh_logs
        self.log_dir.mkdir(parents=True, exist_ok=True)
        if self.run_dir is not None:
            self.run_dir.mkdir(parents=True, exist_ok=True)
        self.processes: dict[str, ManagedProcess] = {}
        for spec in self.nodes:
            process = ManagedProcess(spec.name, spec.module, spec.args, self.log_path(spec.name))
            pid = self.recorded_pid(spec.name)
            if pid is not None:
                process.adopt(pid)
            self.processes[spec.name] = process

    # ------------------------------------------------------------------ bookkeeping
    def log_path(self, name: str) -> Path:
        return self.log_dir / f"{name}.log"

    def pid_path(self, name: str) -> Path | None:
        return self.run_dir / f"{name}.pid" if self.run_dir is not None else None

    def recorded_pid(self, name: str) -> int | None:
        path = self.pid_path(name)
        try:
            return int(path.read_text().strip()) if path is not None and path.exists() else None
        except ValueError:
            return None

    def _forget(self, name: str) -> None:
        path = self.pid_path(name)
        if path is not None:
            path.unlink(missing_ok=True)

    def __getitem__(self, name: str) -> ManagedProcess:
        return self.processes[name]

    def alive(self, name: str) -> bool:
        return self.processes[name].alive()

    def any_alive(self) -> bool:
        return any(p.alive() for p in self.processes.values())

    # ------------------------------------------------------------------ start
    def start(self, timeout: float = 60.0) -> list[str]:
        """Start every node not already running, then wait until all are up. Returns the names
        started. On a node that exits or a timeout, stops what this call started and raises
        BringupError (the reason, with the last lines of the node's log)."""
        os.environ.update({k: v for k, v in self.env.items() if k.startswith("ROS_")})  # the probe's domain
        started: list[str] = []
        try:
            for spec in self.nodes:
                process = self.processes[spec.name]
                if process.alive():
                    self.say(f"{spec.name}: already running (pid {process.pid})")
                    continue
                header = (f"=== {spec.name} started {datetime.now():%Y-%m-%d %H:%M:%S} on "
                          f"ROS_DOMAIN_ID={self.env.get('ROS_DOMAIN_ID', '0')}: {' '.join(spec.args)}")
                pid = process.start(self.env, self.cwd, header if self.fresh_logs else "")
                path = self.pid_path(spec.name)
                if path is not None:
                    path.write_text(f"{pid}\n")
                started.append(spec.name)
                self.say(f"{spec.name}: started (pid {pid}, log {process.log_path})")
            self.wait_ready(timeout, started)
        except BaseException:
            self.stop(list(reversed(started)), report=self.warn)
            raise
        return started

    def wait_ready(self, timeout: float, started: Sequence[str] = ()) -> None:
        """Wait until every node is discovered with what it offers and its last check passes."""
        deadline = time.monotonic() + timeout + 1.0
        pending = list(self.nodes)
        with GraphProbe.shared() as probe:
            while pending:
                still = []
                for spec in pending:
                    process = self.processes[spec.name]
                    if not process.running():
                        raise BringupError(f"{spec.name} exited during start-up; last lines of {process.log_path}:\n"
                                           + process.tail(20))
                    if probe.missing(spec.ready):
                        still.append(spec)
                pending = still
                if not pending:
                    break
                if time.monotonic() >= deadline:
                    gaps = {spec.name: describe(probe.missing(spec.ready)) for spec in pending}
                    raise BringupError(f"{' '.join(gaps)} not ready after {timeout:g} s (not discovered: "
                                       + "; ".join(f"{n}: {g}" for n, g in gaps.items())
                                       + f"); see the logs in {self.log_dir}")
                time.sleep(0.1)
        for spec in self.nodes:
            if spec.check is not None:
                problem = spec.check(max(5.0, deadline - time.monotonic()))
                if problem is not None:
                    raise BringupError(f"{problem}; see the logs in {self.log_dir}")

    # ------------------------------------------------------------------ stop
    def stop(self, names: Sequence[str] | None = None, report: Callable[[str], None] | None = None,
             last: Sequence[str] = ("mycobot_emulator",)) -> None:
        """Stop ``names`` (default: every node, in reverse start order): SIGINT to all first (their
        shutdowns overlap; the planning_server first, so that it stops an execution while the
        controllers still listen), then wait for each, escalating to SIGTERM after 10 s and
        SIGKILL 3 s later. ``last`` are signalled only after the others are gone (the emulated
        arm: the driver sends it a stop command as it shuts down)."""
        say = report or self.say
        order = list(names) if names is not None else [s.name for s in reversed(self.nodes)]
        signalled = []
        for name in order:
            process = self.processes[name]
            if name not in last and process.alive():
                process.signal(signal.SIGINT)
                signalled.append(name)
        for name in [n for n in order if n not in last] + [n for n in order if n in last]:
            process = self.processes[name]
            if process.pid is None:
                say(f"{name}: not running")
                continue
            if name not in signalled and not process.alive():
                self._forget(name)
                say(f"{name}: was not running (pid {process.pid} exited; stale pid file removed)")
                process.pid = None
                continue
            if not process.stop(signalled=name in signalled, report=self.warn):
                raise BringupError(f"{name}: process group {process.pid} survived SIGKILL")
            self._forget(name)
            say(f"{name}: stopped (pid {process.pid})")
            process.pid = None

    def close(self) -> None:
        """Stop everything quietly (a context manager's exit)."""
        self.stop(report=lambda text: None)

    def __enter__(self) -> "Robot":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ status
    def status(self, domain: str = "(unknown)") -> tuple[int, list[str]]:
        """(exit code, lines): 0 when every node runs, 3 when none runs (and none died), else 1."""
        lines, running, dead = [], 0, 0
        for spec in self.nodes:
            process = self.processes[spec.name]
            if process.alive():
                lines.append(f"{spec.name}: running (pid {process.pid}, ROS_DOMAIN_ID={domain}, log {process.log_path})")
                running += 1
            elif process.pid is not None:
                lines.append(f"{spec.name}: dead (pid {process.pid} exited; see log {process.log_path})")
                dead += 1
            else:
                lines.append(f"{spec.name}: not running")
        lines.append(f"logs: {self.log_dir}")
        if running == len(self.nodes):
            return 0, lines
        return (3 if running == 0 and dead == 0 else 1), lines

    def summary(self) -> str:
        return ", ".join(f"{name} (pid {p.pid})" for name, p in self.processes.items())
