"""scripts/demo.sh and scripts/perception_demo.sh: the seeds' pick and place on a robot brought
up for the run (mycobot_planning.ros.bringup), planned and executed by mtc_node, then judged.

    python -m mycobot_planning.ros.demos.robot_demos demo [--hardware PORT|emulated | --sim mujoco] [MTC_NODE_ROS_ARGS...]
    python -m mycobot_planning.ros.demos.robot_demos perception [--sim mujoco] [MTC_NODE_ROS_ARGS...]

The scripts' headers say what each run does and prints; the robot, the optional task viewer
(MYCOBOT_DEMO_VIEWER=1), the camera and the perception_server are one bring-up, stopped at the
end whatever happens (Ctrl-C and SIGTERM included).
"""
from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from interfaces_py.clients import PlanningSceneInterface
from interfaces_py.perception_client import PerceptionClient, RpcError
from mycobot_planning.demos import pick_place_report
from mycobot_planning.demos.pick_place import load_parameters
from mycobot_planning.demos.sim_pick_place import PLANNING_CLEARANCE, floor_object, padded_dimensions
from mycobot_planning.paths import config_file, use_fast_discovery
from mycobot_planning.ros.bringup import robot as bringup
from mycobot_planning.ros.bringup.process import ManagedProcess
from mycobot_planning.ros.bringup.readiness import Readiness
from mycobot_planning.ros.demos.sim_verdict import TwinObserver, twin_verdict, verdict_lines
from mycobot_planning.ros.perception.perception_setup import detection_lines
from mycobot_planning.simulation.scene import load_scene

#: The myCobot's arm group (home: every joint 0); the readback must end within HOME_TOLERANCE.
ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6",
       "link6_to_link6_flange"]
HOME_TOLERANCE = 0.02
CLOUD_TOPIC = "/camera_head/depth/color/points"


class Interrupted(Exception):
    """Ctrl-C or SIGTERM: stop everything and exit 130."""


def _interrupt(*_: object) -> None:
    raise Interrupted()


class Demo:
    """One demo run: its folder, its ROS domain, its bring-up."""

    def __init__(self, tag: str, folder_prefix: str, hardware: str = "", sim: str = "",
                 sim_params: tuple[str, ...] = ()) -> None:
        self.tag = tag
        self.hardware = hardware
        self.sim = sim
        self.sim_params = list(sim_params)
        self.dir = Path(os.environ.get("MYCOBOT_DEMO_DIR") or f"/tmp/mycobot_planning/{folder_prefix}-{os.getpid()}")
        self.dir.mkdir(parents=True, exist_ok=True)
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 100))
        os.environ["PYTHONUNBUFFERED"] = "1"
        self.params = str(config_file("mtc_node_params.yaml"))
        self.node_timeout = float(os.environ.get("MYCOBOT_DEMO_TIMEOUT") or 600)
        self.start_timeout = float(os.environ.get("MYCOBOT_START_TIMEOUT") or 60)
        self.robot: bringup.Robot | None = None
        self.extras: bringup.Robot | None = None
        self.mtc: ManagedProcess | None = None

    def say(self, text: str) -> None:
        print(f"[{self.tag}] {text}", flush=True)

    def warn(self, text: str) -> None:
        print(f"[{self.tag}] {text}", file=sys.stderr, flush=True)

    # ------------------------------------------------------------------ the robot
    def start_robot(self) -> None:
        run_dir = self.dir / "run"
        nodes = bringup.robot_nodes(self.hardware, run_dir, sim=self.sim, sim_params=self.sim_params)
        out = lambda text: print(text, flush=True)  # noqa: E731 - robot.sh's lines, as it prints them
        err = lambda text: print(text, file=sys.stderr, flush=True)  # noqa: E731
        self.robot = bringup.Robot(nodes, self.dir, run_dir, say=out, warn=err)
        try:
            self.robot.start(self.start_timeout)
        except bringup.BringupError as exc:
            # the bring-up stops what it started when a start fails; one more try rides out a slow machine
            err(f"robot.sh: {exc}")
            self.warn("the robot did not come up; trying once more")
            self.robot.start(self.start_timeout)
        print(f"robot up: {self.robot.summary()}; logs in {self.dir}", flush=True)
        if self.hardware:
            port = self.hardware
            if port == "emulated":
                port = f"{run_dir / 'mycobot_port'} (emulated arm; faults: {run_dir / 'mycobot_emulator.sock'})"
            print(f"hardware: mycobot_driver drives the myCobot 280 on {port}", flush=True)
        if self.sim:
            print("simulation: mujoco_sim simulates the arm, the gripper and the objects (MuJoCo)", flush=True)

    def start_extras(self, nodes: list[bringup.NodeSpec]) -> None:
        """The optional nodes (camera, perception, viewer) as one more bring-up in the same folder."""
        if not nodes:
            return
        self.extras = bringup.Robot(nodes, self.dir, warn=self.warn)
        self.extras.start(self.start_timeout)

    def viewer_node(self) -> list[bringup.NodeSpec]:
        port = os.environ.get("MYCOBOT_VIEWER_PORT") or "8080"
        if os.environ.get("MYCOBOT_DEMO_VIEWER", "0") != "1":
            self.say(f"to watch in a browser, run with MYCOBOT_DEMO_VIEWER=1 (serves http://127.0.0.1:{port}/)")
            return []
        return [bringup.extra_node("task_viewer", ["--ros-args", "-p", f"port:={port}"])]

    def report_viewer(self) -> None:
        if self.extras is None or "task_viewer" not in self.extras.processes:
            return
        viewer = self.extras["task_viewer"]
        viewer.wait_for_output("in a browser", 20.0)
        url = next((word for word in viewer.output().split() if word.startswith("http://")), "")
        if url:
            self.say(f"task viewer running: open {url} in a browser")
        else:
            self.warn(f"the task viewer did not start; see {viewer.log_path}")

    # ------------------------------------------------------------------ mtc_node
    def run_mtc_node(self, args: list[str]) -> int:
        """mtc_node in the foreground (its log shown as it grows); its exit code."""
        self.mtc = ManagedProcess("mtc_node", "mycobot_planning.nodes.mtc_node",
                                  ["--ros-args", "--params-file", self.params, "-p", "execute:=true",
                                   "-p", "exit_when_done:=true", *args], self.dir / "mtc_node.log")
        self.mtc.log_path.write_text("")  # this run's log only: the report reads it
        self.mtc.start(bringup.ros_environment())
        shown = 0
        deadline = time.monotonic() + self.node_timeout
        while True:
            running = self.mtc.running()
            text = self.mtc.output()
            if len(text) > shown:
                sys.stdout.write(text[shown:])
                sys.stdout.flush()
                shown = len(text)
            if not running:
                break
            if time.monotonic() > deadline:
                self.warn(f"mtc_node did not finish within {self.node_timeout:g} s; stopping it")
                self.mtc.stop(grace=10.0, signalled=False)
                break
            time.sleep(0.2)
        code = self.mtc.returncode()
        self.mtc = None
        return 1 if code is None else code

    # ------------------------------------------------------------------ the end
    def stop_all(self) -> None:
        if self.mtc is not None:
            self.mtc.stop(grace=10.0)
        if self.extras is not None:
            self.extras.stop(report=lambda text: None)
        self.say("stopping the robot")
        if self.robot is not None:
            try:
                self.robot.stop(report=lambda text: None)
            except bringup.BringupError as exc:
                self.warn(f"stopping the robot reported a problem ({exc}); see {self.dir}")
        self.say(f"logs: {self.dir}")


def arm_ends_at_home(tag: str) -> bool:
    """The arm's own readback (/joint_states) ends at home (every arm joint within HOME_TOLERANCE of 0)."""
    use_fast_discovery()
    context = Context()
    rclpy.init(context=context)
    node = Node("demo_home_check", context=context)
    latest: list[JointState] = []
    node.create_subscription(JointState, "/joint_states", latest.append, 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline = time.monotonic() + 10.0
    try:
        while not latest and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    if not latest:
        print(f"[{tag}] no /joint_states from the arm: cannot check that it ended at home")
        return False
    joints = dict(zip(latest[-1].name, latest[-1].position))
    error = max(abs(joints.get(j, float("inf"))) for j in ARM)
    print(f"[{tag}] arm readback at the end: {[round(joints.get(j, float('nan')), 4) for j in ARM]} rad "
          f"(home: all 0; largest deviation {error:.4f} rad)")
    return error <= HOME_TOLERANCE


def show_detections(params_path: str, timeout: float, truth: Callable[[str], Any] | None = None) -> bool:
    """Ask the perception_server for the parameters' cylinder until it answers; print what it sees
    (and with ``truth`` (object name -> its true 4x4 pose or None), the perception error against it)."""
    params = load_parameters(params_path)
    deadline = time.monotonic() + timeout
    reason = ""
    with PerceptionClient(timeout=30.0) as perception:
        while True:
            try:
                result = perception.get_planning_scene("cylinder", list(params.object_dimensions))
                reason = result.message
            except RpcError as exc:
                result, reason = None, exc.message
            if result or time.monotonic() > deadline:
                break
            time.sleep(1.0)
    if not result:
        print(f"  perception failed: {reason}")
        return False
    print("\n".join("  " + line for line in detection_lines(result.response)))
    if truth is not None:
        target = next((o for o in result.summaries if o.get("id") == result.target_object_id), None)
        true_pose = truth(params.object_name)
        if target is None or true_pose is None:
            print("  perception error: cannot tell (no target, or no true pose from the simulator)")
            return False
        error = float(np.linalg.norm(np.asarray(target["position"], dtype=float) - true_pose[:3, 3]))
        print(f"  perception error: the perceived cylinder's centre is {error * 1000:.1f} mm from the simulated "
              f"one at ({true_pose[0, 3]:.4f}, {true_pose[1, 3]:.4f}, {true_pose[2, 3]:.4f})")
    return True


def run_demo(demo: Demo, body: Callable[[], int]) -> int:
    """Say where the demo runs (its ROS domain, its log folder), run ``body`` and stop everything
    the demo started, whatever happens (Ctrl-C: 130)."""
    previous = {sig: signal.signal(sig, _interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    code = 1
    try:
        demo.say(f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}; logs in {demo.dir}")
        code = body()
    except Interrupted:
        code = 130
    except bringup.BringupError as exc:
        demo.warn(f"the robot did not come up: {exc}")
        code = 1
    finally:
        try:
            demo.stop_all()
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
    return code


def _option(argv: list[str], name: str) -> tuple[str | None, list[str]]:
    """``--name VALUE`` or ``--name=VALUE`` at the front of argv: (value, the rest); value None
    when absent, "" when given empty."""
    if argv and argv[0] == name:
        return (argv[1] if len(argv) > 1 else ""), argv[2:]
    if argv and argv[0].startswith(name + "="):
        return argv[0].split("=", 1)[1], argv[1:]
    return None, argv


def sim_mtc_args(params_path: str, argv: list[str]) -> list[str]:
    """mtc_node's arguments in the twin: the object's planning radius padded by
    PLANNING_CLEARANCE (docs/simulation.md: the planner keeps no distance, and a path that grazes
    the cylinder at half a millimetre knocks it over in physics); the user's arguments after."""
    params = pick_place_report.parameters_with_overrides(params_path, argv)
    return ["-p", f"object_dimensions:={padded_dimensions(params)}", *argv]


def add_sim_floor(tag: str, params_path: str, argv: list[str]) -> None:
    """The twin's floor into the planning_server's scene (the seed's scene has none, and a path may
    swing the carried 35 cm cylinder through it; docs/simulation.md)."""
    scene = load_scene(config_file("mujoco_scene.yaml"))
    if scene.floor is None:
        return
    params = pick_place_report.parameters_with_overrides(params_path, argv)
    with PlanningSceneInterface(timeout=30.0) as psi:
        psi.apply_collision_object(floor_object(scene.floor.z, params.world_frame))
    print(f"[{tag}] added the simulated floor (z = {scene.floor.z:g} m) to the planning scene", flush=True)


def sim_verdict(tag: str, params_path: str, argv: list[str]) -> int:
    """Print the twin's verdict on the object (sim_verdict.py); 0 only when it holds."""
    params = pick_place_report.parameters_with_overrides(params_path, argv)
    print(f"[{tag}] the simulator's verdict (object at rest, against the place pose):", flush=True)
    with TwinObserver(f"demo_sim_verdict_{os.getpid()}") as observer:
        outcome, reason = twin_verdict(observer, params)
    ok, lines = verdict_lines(outcome, reason)
    for line in lines:
        print(line, flush=True)
    return 0 if ok else 1


def pick_place_demo(argv: list[str]) -> int:
    sim, argv = _option(argv, "--sim")
    if sim is not None and sim not in bringup.SIMULATORS:
        print(f"demo.sh: --sim needs a simulator ({', '.join(bringup.SIMULATORS)}), got '{sim}'", file=sys.stderr)
        return 2
    if sim:
        return sim_pick_place_demo(sim, argv)
    hardware = ""
    if argv and argv[0] == "--hardware":
        if len(argv) < 2 or not argv[1]:
            print("demo.sh: --hardware needs a serial port or 'emulated'", file=sys.stderr)
            return 2
        hardware, argv = argv[1], argv[2:]
    elif argv and argv[0].startswith("--hardware="):
        hardware, argv = argv[0].split("=", 1)[1], argv[1:]
        if not hardware:
            print("demo.sh: --hardware needs a serial port or 'emulated'", file=sys.stderr)
            return 2
    demo = Demo("demo", "demo", hardware)

    def body() -> int:
        if hardware:
            where = "the emulated arm" if hardware == "emulated" else hardware
            demo.say(f"starting mycobot_driver on {where} and the planning_server")
        else:
            demo.say("starting the mock controllers and the planning_server")
        demo.start_robot()
        demo.start_extras(demo.viewer_node())
        demo.report_viewer()
        demo.say("running mtc_node (plan, then execute)")
        node_code = demo.run_mtc_node(argv)
        print(f"\n[demo] mtc_node exited with code {node_code}", flush=True)
        check = pick_place_report.main([str(demo.dir / "mtc_node.log"), demo.params, str(node_code), *argv])
        if hardware:
            if arm_ends_at_home("demo"):
                demo.say("the arm's readback ended at home")
            else:
                demo.warn("FAILED: the arm's readback did not end at home")
                check = check or 1
        return check

    return run_demo(demo, body)


def sim_pick_place_demo(sim: str, argv: list[str]) -> int:
    """demo.sh --sim mujoco: mtc_node plans and executes as on the mock, through the twin; the
    verdict is the simulator's."""
    demo = Demo("demo", "demo", sim=sim)

    def body() -> int:
        demo.say("starting mujoco_sim (the MuJoCo twin) and the planning_server")
        demo.start_robot()
        demo.start_extras(demo.viewer_node())
        demo.report_viewer()
        add_sim_floor("demo", demo.params, argv)
        demo.say("running mtc_node (plan, then execute in the simulation)")
        node_code = demo.run_mtc_node(sim_mtc_args(demo.params, argv))
        print(f"\n[demo] mtc_node exited with code {node_code}", flush=True)
        demo.say("what the planning scene says (mtc_node's view; the simulator's verdict follows):")
        pick_place_report.main([str(demo.dir / "mtc_node.log"), demo.params, str(node_code), *argv])
        verdict = sim_verdict("demo", demo.params, argv)
        if node_code != 0:
            demo.warn(f"FAILED: mtc_node exited with code {node_code}")
        return verdict or (1 if node_code != 0 else 0)

    return run_demo(demo, body)


#: perception_server's settings for the twin's world (docs/simulation.md, the depth camera): the
#: floor 3 cm below a 10 x 20 cm table top; the twin's clouds come in its world frame (base_link's origin)
SIM_PERCEPTION_ARGS = ["-p", "z_tolerance:=0.01", "-p", "plane_voxel_leaf_size:=0.008", "-p", "min_cluster_size:=30",
                       "-p", "cloud_frame_id:=world", "-p", "cloud_frame_pose:=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]"]


def sim_perception_demo(sim: str, argv: list[str]) -> int:
    """perception_demo.sh --sim mujoco: the twin's rendered cloud -> perception_server -> mtc_node;
    the perception error against the simulator's truth, and the simulator's verdict."""
    demo = Demo("perception demo", "perception-demo", sim=sim, sim_params=("camera_rate:=1.0",))
    perception_params = str(config_file("perception_server.yaml"))

    def body() -> int:
        demo.say("starting mujoco_sim (the MuJoCo twin, its depth camera at 1 Hz) and the planning_server")
        demo.start_robot()
        demo.say("starting the perception_server on the twin's rendered cloud")
        demo.start_extras([bringup.extra_node("perception_server", ["--ros-args", "--params-file", perception_params,
                                                                   *SIM_PERCEPTION_ARGS]), *demo.viewer_node()])
        add_sim_floor("perception demo", demo.params, argv)
        demo.say("what the perception_server sees:")
        with TwinObserver(f"demo_truth_{os.getpid()}") as observer:
            if not show_detections(demo.params, demo.start_timeout,
                                   truth=lambda name: observer.wait_for_pose(name, demo.start_timeout)):
                return 1
        demo.report_viewer()
        demo.say(f"running mtc_node with use_perception:=true, the perceived cylinder padded by "
                 f"{PLANNING_CLEARANCE * 1000:g} mm for planning (plan, then execute in the simulation)")
        node_code = demo.run_mtc_node(["-p", "use_perception:=true", "-p", "perception_server:=/perception_server",
                                       "-p", f"perception_padding:={PLANNING_CLEARANCE}", *argv])
        print(f"\n[perception demo] mtc_node exited with code {node_code}", flush=True)
        demo.say("what the planning scene says (mtc_node's view; the simulator's verdict follows):")
        pick_place_report.main(["--perception", str(demo.dir / "mtc_node.log"), demo.params, str(node_code), *argv])
        verdict = sim_verdict("perception demo", demo.params, argv)
        if node_code != 0:
            demo.warn(f"FAILED: mtc_node exited with code {node_code}")
        return verdict or (1 if node_code != 0 else 0)

    return run_demo(demo, body)


def perception_demo(argv: list[str]) -> int:
    sim, argv = _option(argv, "--sim")
    if sim is not None and sim not in bringup.SIMULATORS:
        print(f"perception_demo.sh: --sim needs a simulator ({', '.join(bringup.SIMULATORS)}), got '{sim}'",
              file=sys.stderr)
        return 2
    if sim:
        return sim_perception_demo(sim, argv)
    demo = Demo("perception demo", "perception-demo")
    perception_params = str(config_file("perception_server.yaml"))

    def body() -> int:
        demo.say("starting the mock controllers and the planning_server")
        demo.start_robot()
        demo.say("starting the camera_simulator and the perception_server")
        demo.start_extras([
            bringup.extra_node("camera_simulator", ["--ros-args", "-p", "rate:=1.0"],
                               ready=Readiness(nodes=("/camera_simulator",), topics=(CLOUD_TOPIC,))),
            bringup.extra_node("perception_server", ["--ros-args", "--params-file", perception_params]),
            *demo.viewer_node()])
        demo.say("what the perception_server sees:")
        if not show_detections(demo.params, demo.start_timeout):
            return 1
        demo.report_viewer()
        demo.say("running mtc_node with use_perception:=true (plan, then execute)")
        node_code = demo.run_mtc_node(["-p", "use_perception:=true", "-p", "perception_server:=/perception_server",
                                       *argv])
        print(f"\n[perception demo] mtc_node exited with code {node_code}", flush=True)
        return pick_place_report.main(["--perception", str(demo.dir / "mtc_node.log"), demo.params, str(node_code),
                                       *argv])

    return run_demo(demo, body)


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] not in ("demo", "perception"):
        print(__doc__.strip().splitlines()[3].strip(), file=sys.stderr)
        return 2
    return pick_place_demo(args[1:]) if args[0] == "demo" else perception_demo(args[1:])


if __name__ == "__main__":
    sys.exit(main())
