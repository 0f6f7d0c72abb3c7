"""Start-up and shutdown of workflow nodes: scripts that do one job through ROS and exit.

The seeds' move_group programs (ROSCon exercise 1-1 and 1-2, Scan-N-Plan's application node) are
C++ ``main`` functions: create a node, spin it in a background thread, plan and execute through
MoveIt, and return. Our workflow nodes do the same with rclpy and the interfaces_py clients:
:func:`run_workflow` creates the node (its parameters declared and validated through
node_runtime), spins it on a background executor so the blocking clients get their answers, calls
``node.run()`` in the main thread and turns the outcome into the exit code:

* 0 when ``run()`` returns;
* 1 with one ``[ERROR]`` log line when a step fails (:class:`WorkflowFailed`: which step and why),
  or when the configuration is bad (a parameter refused), never a traceback;
* 130 on Ctrl-C / SIGTERM.
"""
from __future__ import annotations

import functools
import signal
import sys
import time
from typing import Any, Callable

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.clients import MoveGroupClient, PlanResult, RpcError
from interfaces_py.msgs import MoveItErrorCode, RobotTrajectory
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.paths import use_fast_discovery

__all__ = ["WorkflowFailed", "WorkflowNode", "run_workflow", "PLANNING_SPECS"]


class WorkflowFailed(Exception):
    """A workflow step failed; the message says which step and why (it is the exit message)."""


@functools.lru_cache(maxsize=1)
def _pipelines() -> PlanningPipeline:
    """The package's pipelines, for checking planner ids when they are set (the planning_server
    plans with the same configuration files)."""
    return PlanningPipeline()


#: Planning request parameters every move_group workflow declares (MoveIt's plan_request_params).
PLANNING_SPECS = [
    ParameterSpec("group", "arm", "planning group to move", non_empty=True),
    ParameterSpec("planning_pipeline", "ompl", "planning pipeline: ompl, pilz_industrial_motion_planner, "
                  "joint_interpolation, stomp or chomp", non_empty=True),
    ParameterSpec("planner_id", "", "planner id (empty: the pipeline's default, RRTConnect for ompl)",
                  validator=lambda value: _pipelines().planner_id_problem(value)),
    ParameterSpec("planning_time", 5.0, "allowed planning time per attempt in seconds", range=(0.01, 600.0)),
    ParameterSpec("planning_attempts", 5, "plan() calls before giving up (the seed retries 5 times)",
                  range=(1, 100)),
    ParameterSpec("max_velocity_scaling_factor", 1.0, "velocity scaling of planned trajectories",
                  range=(0.0001, 1.0)),
    ParameterSpec("max_acceleration_scaling_factor", 1.0, "acceleration scaling of planned trajectories",
                  range=(0.0001, 1.0)),
    ParameterSpec("planning_server", "/planning_server", "the planning_server node to talk to", non_empty=True),
    ParameterSpec("server_timeout", 30.0, "seconds to wait for the planning_server to answer at start-up",
                  range=(0.1, 3600.0)),
]


class WorkflowNode(Node):
    """A node that runs one workflow (override :meth:`run`) with declared parameters."""

    def __init__(self, name: str, specs: list[ParameterSpec]) -> None:
        super().__init__(name)
        self.params = Parameters(self, specs)
        self._executing: MoveGroupClient | None = None  # the client whose execution is under way

    def run(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    # ---- helpers shared by the move_group workflows
    def move_group(self) -> MoveGroupClient:
        """A MoveGroupClient on this node, configured from the planning parameters, once the
        planning_server answers (WorkflowFailed otherwise)."""
        p = self.params
        arm = MoveGroupClient(p.get("group"), node=self, server=p.get("planning_server"), timeout=15.0)
        arm.set_pipeline_id(p.get("planning_pipeline"))
        if p.get("planner_id"):
            arm.set_planner_id(p.get("planner_id"))
        arm.set_planning_time(float(p.get("planning_time")))
        arm.set_max_velocity_scaling_factor(float(p.get("max_velocity_scaling_factor")))
        arm.set_max_acceleration_scaling_factor(float(p.get("max_acceleration_scaling_factor")))
        timeout = float(p.get("server_timeout"))
        self.get_logger().info(f"waiting for {p.get('planning_server')} (up to {timeout:g} s)")
        if not arm.wait_for_server(timeout):
            raise WorkflowFailed(f"no planning_server answering at {p.get('planning_server')} within {timeout:g} s: "
                                 "start it first (scripts/robot.sh start)")
        # the server needs the robot's state before it can plan from it
        deadline = time.monotonic() + timeout
        while True:
            state = arm.call("get_state")
            if state.get("joint_state_received"):
                break
            if time.monotonic() > deadline:
                raise WorkflowFailed("the planning_server has no joint states: are the controllers running "
                                     "(scripts/robot.sh start)?")
            time.sleep(0.1)
        return arm

    def plan(self, arm: MoveGroupClient, what: str) -> RobotTrajectory:
        """Plan to the target set on ``arm``, retrying up to ``planning_attempts`` times (RRTConnect
        is randomised: a failed attempt may succeed the next time)."""
        attempts = int(self.params.get("planning_attempts"))
        last: MoveItErrorCode | None = None
        for attempt in range(1, attempts + 1):
            result: PlanResult = arm.plan()
            if result:
                trajectory = result.trajectory
                self.get_logger().info(
                    f"planned {what} (attempt {attempt}/{attempts}): {trajectory.joint_trajectory.duration:.2f} s "
                    f"trajectory, {len(trajectory.joint_trajectory.points)} points, planning time "
                    f"{result.planning_time:.3f} s")
                return trajectory
            last = result.error_code
            self.get_logger().warning(f"planning {what} failed (attempt {attempt}/{attempts}): {last}")
            if last.val in (MoveItErrorCode.INVALID_GROUP_NAME, MoveItErrorCode.TIMED_OUT,
                            MoveItErrorCode.COMMUNICATION_FAILURE, MoveItErrorCode.ROBOT_STATE_STALE):
                break  # retrying cannot help
        raise WorkflowFailed(f"planning {what} failed after {attempt} attempt(s): {last}")

    def execute(self, arm: MoveGroupClient, trajectory: RobotTrajectory, what: str) -> None:
        self.get_logger().info(f"executing {what} ({trajectory.joint_trajectory.duration:.2f} s)")
        self._executing = arm  # stays set if Ctrl-C interrupts the wait: interrupted() stops it
        code = arm.execute(trajectory)
        self._executing = None
        if not code:
            raise WorkflowFailed(f"executing {what} failed: {code}")
        self.get_logger().info(f"executed {what}")

    def interrupted(self) -> None:
        """Ctrl-C / SIGTERM: a script that is stopped while the robot moves stops the robot
        (the planning_server would otherwise finish the trajectory on its own)."""
        arm = self._executing
        if arm is None:
            return
        # The execute request may still be on its way (the server has not started it): keep
        # asking for a moment rather than letting it start after a "nothing is executing".
        deadline = time.monotonic() + 1.0
        try:
            while not arm.stop():
                if time.monotonic() > deadline:
                    return
                time.sleep(0.02)
        except Exception as exc:  # the server may be gone too: say so, do not hide the interrupt
            self.get_logger().warning(f"could not stop the running execution: {exc}")
            return
        self.get_logger().warning("stopped the running execution")


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def run_workflow(factory: Callable[[], WorkflowNode], args: list[str] | None = None) -> int:
    """Create the node, spin it in the background, run its workflow; the exit code (see module)."""
    use_fast_discovery()
    # No rclpy signal handlers: rclpy's would shut the context down on Ctrl-C while the main thread
    # waits for an answer (it would wait for its timeout, and could no longer stop the robot).
    # Ctrl-C and SIGTERM raise KeyboardInterrupt in the main thread instead.
    rclpy.init(args=args if args is not None else sys.argv, signal_handler_options=SignalHandlerOptions.NO)
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    node: WorkflowNode | None = None
    spinner: BackgroundSpin | None = None
    code = 0
    try:
        try:
            node = factory()
        except ValueError as exc:  # bad configuration: one line, no traceback
            print(f"[ERROR] {exc}", file=sys.stderr)
            return 1
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        spinner = BackgroundSpin(executor, name=f"{node.get_name()} executor")
        try:
            node.run()
            node.get_logger().info("done")
        except (WorkflowFailed, ValueError) as exc:
            node.get_logger().error(str(exc))
            code = 1
        except RpcError as exc:  # a request the workflow did not expect to fail (e.g. a timeout)
            node.get_logger().error(f"a request to a server failed: {exc}")
            code = 1
    except KeyboardInterrupt:
        if node is not None:
            node.get_logger().warning("interrupted")
            node.interrupted()
        code = 130
    finally:
        if spinner is not None:
            spinner.stop()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code
