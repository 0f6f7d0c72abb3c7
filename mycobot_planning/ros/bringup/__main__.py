"""``scripts/robot.sh``: start, stop, restart or report the robot in the background.

    python -m mycobot_planning.ros.bringup start|stop|restart|status [options] [-- ARGS]

The commands, options, messages and exit codes are robot.sh's (see USAGE).
"""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path

from mycobot_planning.ros.bringup.robot import SIMULATORS, BringupError, Robot, robot_nodes

PROG = "robot.sh"
USAGE = """\
Usage: scripts/robot.sh start|stop|restart|status [--log-dir DIR] [--run-dir DIR] [--timeout S]
                        [--hardware PORT|emulated [--driver-param NAME:=VALUE]...]
                        [--sim mujoco [--sim-param NAME:=VALUE]...]
                        [-- PLANNING_SERVER_ROS_ARGS...]

  start    start mock_controllers, robot_state_publisher and planning_server in the background (each
           in a process group of its own), then wait until all are up: ROS discovery shows their
           nodes, services and actions, and the planning_server answers get_state with joint states
           received. Prints the PIDs and the log folder. A node that is already running is not
           started again (start is idempotent). If a node dies or the wait times out, whatever this
           start launched is stopped again and the exit code is 1.
  stop     stop them all: SIGINT to each tracked process group, SIGTERM after 10 s, SIGKILL after 3 s
           more. Only the PIDs recorded by start are signalled, never processes found by name.
  restart  stop, then start.
  status   what runs: PID, alive or dead, log file of each node. Exit code 0 when all run,
           3 when none runs, 1 otherwise (some of them only, or a node that died).

Options:
  --log-dir DIR  log folder (default $MYCOBOT_LOG_DIR or /tmp/mycobot_planning/logs); one file
                 per node, <node>.log, the previous run's kept as <node>.log.1
  --run-dir DIR  PID files (default $MYCOBOT_RUN_DIR or /tmp/mycobot_planning/run)
  --timeout S    seconds start waits for the nodes to be up (default $MYCOBOT_START_TIMEOUT or 60)
  --hardware PORT|emulated
                 start/restart: drive the real myCobot 280 on serial port PORT (e.g. /dev/ttyUSB0)
                 with mycobot_driver instead of the mock controllers (same controllers and actions;
                 /joint_states from the arm's readback). "emulated" first starts mycobot_emulator,
                 an emulated arm on a pseudo-terminal (its port: RUN_DIR/mycobot_port, its fault
                 control socket: RUN_DIR/mycobot_emulator.sock), and drives that.
  --driver-param NAME:=VALUE
                 a parameter for mycobot_driver (repeatable), e.g. --driver-param model:=Pi
                 --driver-param command_rate:=20.0
  --sim mujoco   start/restart: the MuJoCo physics twin (node mujoco_sim) instead of the mock
                 controllers: same controllers and actions over a simulated arm, gripper and
                 world (config/mujoco_scene.yaml); /joint_states from the simulated joints, the
                 objects' true poses on /mujoco_sim/object_poses, its status on /mujoco_sim/status
  --sim-param NAME:=VALUE
                 a parameter for mujoco_sim (repeatable), e.g. --sim-param speed_factor:=0.5

Everything after "--" is handed to the planning_server as ROS arguments, after "--ros-args"
(added unless you start with it), e.g.:
  scripts/robot.sh start -- -p planning_time:=2.0 -p trajectory_execution.allowed_start_tolerance:=0.02
  scripts/robot.sh start -- --params-file config/planning_server.yaml
They are used only when the planning_server is (re)started.

Environment: ROS_DOMAIN_ID is honoured (the nodes join that domain; status shows the domain
they were started on). ROS_AUTOMATIC_DISCOVERY_RANGE is set to LOCALHOST unless already set.
The Python of .venv runs the nodes; scripts/setup.sh creates .venv first if it is missing.
"""


class UsageError(Exception):
    def __init__(self, message: str, code: int = 1, usage: bool = False) -> None:
        super().__init__(message)
        self.code, self.usage = code, usage


def out(text: str) -> None:
    print(text, flush=True)


def err(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


class Options:
    def __init__(self, argv: list[str]) -> None:
        self.command = ""
        self.log_dir = os.environ.get("MYCOBOT_LOG_DIR") or "/tmp/mycobot_planning/logs"
        self.run_dir = os.environ.get("MYCOBOT_RUN_DIR") or "/tmp/mycobot_planning/run"
        self.timeout = os.environ.get("MYCOBOT_START_TIMEOUT") or "60"
        self.hardware = ""
        self.driver_params: list[str] = []
        self.sim = ""
        self.sim_params: list[str] = []
        self.server_args: list[str] = []
        self.help = False
        self._parse(list(argv))

    def _value(self, args: list[str], i: int, what: str) -> str:
        if i + 1 >= len(args):
            raise UsageError(f"{args[i]} needs {what}")
        return args[i + 1]

    def _parse(self, args: list[str]) -> None:
        i = 0
        while i < len(args):
            a = args[i]
            if a in ("-h", "--help"):
                self.help = True
                return
            if a == "--":
                self.server_args = args[i + 1:]
                break
            key, eq, inline = a.partition("=")
            if key in ("--log-dir", "--run-dir", "--timeout", "--hardware", "--driver-param", "--sim",
                       "--sim-param") and (eq or key == a):
                what = {"--log-dir": "a folder", "--run-dir": "a folder", "--timeout": "seconds",
                        "--hardware": "a serial port or 'emulated'", "--driver-param": "NAME:=VALUE",
                        "--sim": "a simulator (mujoco)", "--sim-param": "NAME:=VALUE"}[key]
                value = inline if eq else self._value(args, i, what)
                i += 1 if eq else 2
                if key == "--log-dir":
                    self.log_dir = value
                elif key == "--run-dir":
                    self.run_dir = value
                elif key == "--timeout":
                    self.timeout = value
                elif key == "--sim":
                    if value not in SIMULATORS:
                        raise UsageError(f"--sim needs a simulator ({', '.join(SIMULATORS)}), got '{value}'")
                    self.sim = value
                elif key == "--sim-param":
                    if ":=" not in value:
                        raise UsageError("--sim-param needs NAME:=VALUE")
                    self.sim_params.append(value)
                elif key == "--hardware":
                    if not value:
                        raise UsageError("--hardware needs a serial port or 'emulated'")
                    self.hardware = value
                else:
                    if ":=" not in value:
                        raise UsageError("--driver-param needs NAME:=VALUE")
                    self.driver_params.append(value)
                continue
            if a in ("start", "stop", "restart", "status"):
                if self.command:
                    raise UsageError(f"one command only (got '{self.command}' and '{a}'); see --help")
                self.command = a
                i += 1
                continue
            raise UsageError(f"unknown argument '{a}'", usage=True)
        if self.help:
            return
        if not self.command:
            raise UsageError("", code=2, usage=True)
        if not re.fullmatch(r"[0-9]+([.][0-9]+)?", self.timeout):
            raise UsageError(f"--timeout must be a number of seconds, got '{self.timeout}'")
        starting = self.command in ("start", "restart")
        if self.server_args and not starting:
            raise UsageError("arguments after -- are for start/restart only")
        if (self.hardware or self.driver_params) and not starting:
            raise UsageError("--hardware and --driver-param are for start/restart only")
        if self.driver_params and not self.hardware:
            raise UsageError("--driver-param needs --hardware")
        if (self.sim or self.sim_params) and not starting:
            raise UsageError("--sim and --sim-param are for start/restart only")
        if self.sim_params and not self.sim:
            raise UsageError("--sim-param needs --sim")
        if self.sim and self.hardware:
            raise UsageError("--sim and --hardware exclude each other: a robot is simulated or real")


class RobotScript:
    """robot.sh's commands over :class:`Robot`, with the run folder's records: the domain the
    robot runs on (``ros_domain_id``), its nodes (``nodes``), its hardware (``hardware``) or
    simulator (``sim``)."""

    def __init__(self, options: Options) -> None:
        self.o = options
        self.log_dir = Path(options.log_dir).resolve()
        self.run_dir = Path(options.run_dir).resolve()
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.domain = os.environ.get("ROS_DOMAIN_ID", "0") or "0"

    def _record(self, name: str) -> str:
        path = self.run_dir / name
        return path.read_text().strip() if path.exists() else ""

    def _robot(self, hardware: str, server_args: list[str] | None = None, sim: str = "") -> Robot:
        return Robot(robot_nodes(hardware, self.run_dir, server_args or [], self.o.driver_params, sim,
                                 self.o.sim_params), self.log_dir, self.run_dir, say=out, warn=err)

    def recorded(self) -> Robot:
        """The robot the run folder recorded (the mock's when nothing is recorded)."""
        if not self._record("nodes"):
            return self._robot("")
        return self._robot(self._record("hardware"), sim=self._record("sim"))

    def stop(self) -> int:
        self.recorded().stop()
        for name in ("ros_domain_id", "nodes", "hardware", "sim"):
            (self.run_dir / name).unlink(missing_ok=True)
        return 0

    def status(self) -> int:
        code, lines = self.recorded().status(self._record("ros_domain_id") or "(unknown)")
        for line in lines:
            out(line)
        return code

    def start(self) -> int:
        wanted = self._robot(self.o.hardware, self.o.server_args, self.o.sim)
        current = self.recorded() if self._record("nodes") else wanted
        if self._record("ros_domain_id") and current.any_alive() and self._record("ros_domain_id") != self.domain:
            raise UsageError(f"the robot of {self.run_dir} already runs on ROS_DOMAIN_ID="
                             f"{self._record('ros_domain_id')}, not {self.domain}: stop it first or use another --run-dir")
        names = [s.name for s in wanted.nodes]
        if [s.name for s in current.nodes] != names and current.any_alive():
            raise UsageError(f"this run dir runs {' '.join(s.name for s in current.nodes)}, not {' '.join(names)}: "
                             "stop it first (scripts/robot.sh stop) or use another --run-dir")
        if self.o.hardware and self._record("hardware") not in ("", self.o.hardware) and current.any_alive():
            raise UsageError(f"this run dir drives the arm on {self._record('hardware')}, not {self.o.hardware}: "
                             "stop it first")
        (self.run_dir / "ros_domain_id").write_text(self.domain + "\n")
        (self.run_dir / "nodes").write_text(" ".join(names) + "\n")
        if self.o.hardware:
            (self.run_dir / "hardware").write_text(self.o.hardware + "\n")
        else:
            (self.run_dir / "hardware").unlink(missing_ok=True)
        if self.o.sim:
            (self.run_dir / "sim").write_text(self.o.sim + "\n")
        else:
            (self.run_dir / "sim").unlink(missing_ok=True)
        out(f"ROS_DOMAIN_ID={self.domain} ROS_AUTOMATIC_DISCOVERY_RANGE="
            f"{os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE']}; logs: {self.log_dir}")
        if self.o.server_args and wanted.alive("planning_server"):
            err("robot.sh: planning_server already runs; arguments after -- ignored (restart to apply them)")
        try:
            wanted.start(float(self.o.timeout))
        except BringupError as exc:
            err(f"{PROG}: {exc}")
            if "mycobot_driver" in names and "planning_server is not ready" in str(exc):
                err(f"{PROG}: no joint states from the arm; last lines of {wanted['mycobot_driver'].log_path}:")
                err(wanted["mycobot_driver"].tail(5))
            if not wanted.any_alive():
                for name in ("ros_domain_id", "nodes", "hardware", "sim"):
                    (self.run_dir / name).unlink(missing_ok=True)
            return 1
        out(f"robot up: {wanted.summary()}; logs in {self.log_dir}")
        if self.o.hardware:
            port = self.o.hardware
            if port == "emulated":
                port = (f"{self.run_dir / 'mycobot_port'} (emulated arm; faults: "
                        f"{self.run_dir / 'mycobot_emulator.sock'})")
            out(f"hardware: mycobot_driver drives the myCobot 280 on {port}")
        if self.o.sim:
            out("simulation: mujoco_sim simulates the arm, the gripper and the objects (MuJoCo); object poses on "
                "/mujoco_sim/object_poses, status on /mujoco_sim/status")
        return 0


def main(argv: list[str] | None = None) -> int:
    try:
        options = Options(sys.argv[1:] if argv is None else argv)
        if options.help:
            out(USAGE.rstrip("\n"))
            return 0
        script = RobotScript(options)
        if options.command == "stop":
            return script.stop()
        if options.command == "status":
            return script.status()
        if options.command == "restart":
            script.stop()
        return script.start()
    except UsageError as exc:
        if exc.usage:
            err(USAGE.rstrip("\n"))
        if str(exc):
            err(f"{PROG}: {exc}")
        return exc.code
    except BringupError as exc:
        err(f"{PROG}: {exc}")
        return 1


if __name__ == "__main__":
    sys.exit(main())
