"""The shared base of the task nodes (modular, fallbacks_move_to, ik_clearance_cost, mtc_node, ...).

The full story: docs/nodes.md, section mycobot_planning.ros.task.task_node.
"""
from __future__ import annotations

import math
import sys
import threading
import time
from typing import Any, Callable, Sequence

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

import rclpy
from interfaces_py.clients import MoveGroupClient, PlanningSceneInterface, RpcError, RpcTimeout
from interfaces_py.msgs import (
    JointTrajectory,
    JointTrajectoryPoint,
    MessageError,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
)
from interfaces_py.ros_conversions import joint_trajectory_to_msg
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec, run_node
from mycobot_planning.ros.task.task_ros_interface import TaskRosInterface
from mycobot_planning.ros.task.task_topics import TaskIntrospection
from mycobot_planning.task import InitStageException, Task, TaskError

__all__ = [
    "DISPLAY_QOS",
    "EXIT_EXECUTION_FAILED",
    "EXIT_PLANNING_FAILED",
    "TaskNode",
    "display_trajectory",
    "run_task_node",
    "solution_lines",
    "stage_summary_lines",
    "task_node_parameters",
]

EXIT_PLANNING_FAILED = 2
EXIT_EXECUTION_FAILED = 3
#: s between two statistics messages, and two progress lines in the log, while a task plans
PROGRESS_PERIOD = 0.1
PROGRESS_LOG_PERIOD = 1.0
#: Same QoS as the planning_server's /planned_path publisher (latched).
DISPLAY_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
MAX_LOGGED_SOLUTIONS = 10
_ACK_TIMEOUT = 3.0  # s: at exit, wait this long for subscribers to receive the latched topics


# ---------------------------------------------------------------------------- ROS-free helpers
def _server_name(value: Any) -> str | None:
    if not isinstance(value, str) or not value.strip():
        return "planning_server must name the planning server node, e.g. /planning_server"
    if any(c.isspace() for c in value):
        return f"planning_server must be a node name without spaces, got {value!r}"
    return None


def task_node_parameters(max_solutions: int = 0, seed: int = 0) -> list[ParameterSpec]:
    """The base parameters (defaults for max_solutions and seed per node)."""
    return [
        ParameterSpec("execute", False, "execute the best solution through the planning_server after the start-up "
                      "planning; setting it to true later executes the current best solution"),
        ParameterSpec("exit_when_done", False, "exit after the start-up planning (and execution): code 0 on "
                      f"success, {EXIT_PLANNING_FAILED} if planning failed, {EXIT_EXECUTION_FAILED} if execution "
                      "failed; false: keep spinning (services ~/plan and ~/execute)"),
        ParameterSpec("max_solutions", int(max_solutions), "stop planning once this many solutions exist (0: all)",
                      range=(0, 100000)),
        ParameterSpec("planning_timeout", 0.0, "overall planning time limit in seconds (0: none)",
                      range=(0.0, 3600.0)),
        ParameterSpec("seed", int(seed), "random seed of the task's sampling (IK restarts, OMPL); -1: different "
                      "every time", range=(-1, 2**31 - 1)),
        ParameterSpec("planning_server", "/planning_server", "name of the planning_server node (scene and execution)",
                      read_only=True, validator=_server_name),
        ParameterSpec("server_timeout", 10.0, "seconds to wait for the planning_server to answer",
                      range=(0.1, 600.0)),
        ParameterSpec("exit_linger", 1.0, "with exit_when_done: the node lives at least this many seconds, so "
                      "subscribers still discovering it receive its latched task topics", range=(0.0, 60.0)),
    ]


def stage_summary_lines(task: Task) -> list[str]:
    """The seeds' "Stage summary": one line per top-level stage."""
    return [f"  {stage.name}: {len(stage.solutions)} solutions, {len(stage.failures)} failures"
            for stage in task.stages]


def solution_lines(task: Task, limit: int = MAX_LOGGED_SOLUTIONS) -> list[str]:
    """Cheapest-first solutions with cost and the comments of their steps (e.g. the Clearance
    cost's closest links), at most ``limit`` of them."""
    lines = []
    for k, solution in enumerate(task.solutions[:limit], start=1):
        comments = [solution.comment] if solution.comment else []
        subs = solution.sub_trajectories()
        for sub in subs:
            if sub.comment:
                creator = sub.creator.name if sub.creator is not None else "?"
                comments.append(f"{creator}: {sub.comment}")
        cost = f"{solution.cost:.4f}" if math.isfinite(solution.cost) else str(solution.cost)
        names = [sub.creator.name for sub in subs if sub.creator is not None]
        steps = " → ".join(names) if len(names) <= 4 else f"{len(names)} steps"
        lines.append(f"  solution {k}: cost {cost}, {steps}" + (f" ({'; '.join(comments)})" if comments else ""))
    if len(task.solutions) > limit:
        lines.append(f"  ... and {len(task.solutions) - limit} more")
    return lines


def display_trajectory(task: Task, solution=None) -> JointTrajectory:
    """The solution as one JointTrajectory for /planned_path: positions and velocities
    (planned trajectories are cubic splines, see execution.timed_to_joint_trajectory), times from
    0. A solution that does not move (e.g. an IK solution) is shown as its end state (one point
    over the active joints)."""
    trajectory = task.joint_trajectory(solution)
    if trajectory.points:
        return JointTrajectory(joint_names=list(trajectory.joint_names), points=[
            JointTrajectoryPoint(positions=list(p.positions), velocities=list(p.velocities),
                                 time_from_start=p.time_from_start) for p in trajectory.points])
    chosen = solution if solution is not None else task.solutions[0]
    state = chosen.end.scene.current_state
    return JointTrajectory(joint_names=list(state.model.variable_names), points=[
        JointTrajectoryPoint(positions=[float(v) for v in state.positions],
                             velocities=[0.0] * len(state.positions), time_from_start=0.0)])


# ---------------------------------------------------------------------------- the node
class TaskNode(Node):
    """Base class of task nodes; subclasses implement :meth:`build_task` (see docs/nodes.md (mycobot_planning.ros.task.task_node)).

    Public API for subclasses and tests:

    * ``model`` (RobotModel), ``params`` (node_runtime.Parameters; ``params.get(name)``),
      ``seed`` (int | None), ``task`` (the last planned Task or None), ``exit_code``.
    * ``build_task() -> Task`` (override): a fresh task for every plan.
    * ``prepare() -> None`` (override, optional): runs on the worker thread once before the
      start-up planning, e.g. to add objects to the planning_server through ``scene_interface``.
    * ``plan() -> bool`` / ``execute() -> MoveItErrorCode``: blocking, one at a time; what
      the services and the start-up run call.
    * ``fetch_scene(timeout) -> PlanningScene``: the planning_server's current scene.
    * ``scene_interface`` (interfaces_py PlanningSceneInterface on this node) and
      ``move_group(group)`` (a MoveGroupClient on this node) for talking to the planning_server
      from the worker thread or a service callback (never from the constructor).
    """

    def __init__(self, node_name: str, *, parameters: Sequence[ParameterSpec] = (), title: str | None = None,
                 max_solutions: int = 0, seed: int = 0, model: RobotModel | None = None) -> None:
        super().__init__(node_name)
        self._created = time.monotonic()
        self.title = title or node_name
        # The model first: parameters naming groups, links or named states are checked against it.
        self.robot_params = Parameters(self, [ParameterSpec(
            "robot_config", "", "robot configuration directory (the setup assistant's output, or a folder with one "
            "URDF and one SRDF) to plan for; use the planning_server's; empty: the package's myCobot 280",
            read_only=True)])
        self.model = model if model is not None else self.load_model()
        self.params = Parameters(self, [*task_node_parameters(max_solutions, seed), *parameters])
        #: Why the last plan failed (empty after a success): what the ~/plan service answers.
        self.last_failure = ""
        self.task: Task | None = None
        self.exit_code: int | None = None
        self._lock = threading.Lock()  # one plan or execution at a time
        self._closing = threading.Event()
        self._worker: threading.Thread | None = None
        self._group = ReentrantCallbackGroup()
        server = self.params.get("planning_server")
        self.scene_interface = PlanningSceneInterface(node=self, server=server,
                                                      timeout=float(self.params.get("server_timeout")))
        self._move_groups: dict[str, MoveGroupClient] = {}
        self.move_group("arm")  # the planning client, created before the executor spins
        #: execution through MTC's execute_task_solution action, as MTC's Task::execute does
        self._task_ros = TaskRosInterface(self, callback_group=self._group)
        self.introspection = TaskIntrospection(self)
        self._display_pub = self.create_publisher(JointTrajectoryMsg, "/planned_path", DISPLAY_QOS)
        self.create_service(Trigger, "~/plan", self._srv_plan, callback_group=self._group)
        self.create_service(Trigger, "~/execute", self._srv_execute, callback_group=self._group)
        self.params.on_change(self._on_params)
        # Start the work once the executor spins, i.e. after the subclass's constructor finished.
        self._start_timer = self.create_timer(0.0, self._start, callback_group=self._group)
        self.info(f"Starting {self.title}")

    # ------------------------------------------------------------------ hooks
    def load_model(self) -> RobotModel:
        """The robot model: the ``robot_config`` directory's, else the package's myCobot 280 (as the
        planning_server loads them)."""
        directory = self.robot_params.get("robot_config")
        return RobotModel.from_config(directory) if directory else RobotModel.mycobot()

    def build_task(self) -> Task:  # pragma: no cover - abstract
        raise NotImplementedError("a TaskNode subclass must implement build_task()")

    def prepare(self) -> None:
        """Runs once on the worker thread before the start-up planning (default: nothing)."""

    # ------------------------------------------------------------------ logging
    # One call site per severity: rclpy refuses a call site whose severity changes.
    def info(self, text: str) -> None:
        self.get_logger().info(text)

    def warning(self, text: str) -> None:
        self.get_logger().warning(text)

    def error(self, text: str) -> None:
        self.get_logger().error(text)

    # ------------------------------------------------------------------ properties
    @property
    def seed(self) -> int | None:
        value = int(self.params.get("seed"))
        return None if value < 0 else value

    @property
    def server_timeout(self) -> float:
        return float(self.params.get("server_timeout"))

    def move_group(self, group: str = "arm") -> MoveGroupClient:
        """A MoveGroupClient for ``group`` sharing this node (created once per group)."""
        client = self._move_groups.get(group)
        if client is None:
            client = MoveGroupClient(group, node=self, server=self.params.get("planning_server"),
                                     timeout=self.server_timeout)
            self._move_groups[group] = client
        return client

    # ------------------------------------------------------------------ scene provider
    def fetch_scene(self, timeout: float) -> PlanningScene:
        """The planning_server's current scene as a core PlanningScene. Waits up to the larger of
        ``timeout`` and ``server_timeout`` (the server may still be starting). Raises
        TimeoutError / ValueError, which CurrentState reports as its failure comment."""
        wait = max(float(timeout), self.server_timeout)
        try:
            data = self.scene_interface.call("get_planning_scene", {}, wait)
        except RpcTimeout as exc:
            raise TimeoutError(exc.message) from None
        except RpcError as exc:
            raise ValueError(f"planning_server refused get_planning_scene: {exc.message}") from None
        try:
            msg = PlanningSceneMsg.from_dict(data)
            if msg.robot_model_name and msg.robot_model_name != self.model.name:
                raise ValueError(f"the planning_server plans for robot '{msg.robot_model_name}', this node for "
                                 f"'{self.model.name}'")
            return PlanningScene.from_msg(self.model, msg)
        except (MessageError, PlanningError) as exc:
            raise ValueError(f"unusable scene from the planning_server: {exc}") from None

    # ------------------------------------------------------------------ planning
    def plan(self) -> bool:
        """Build the task, plan it, log and publish the outcome. True when solutions exist."""
        with self._lock:
            return self._plan_locked()

    def _fail(self, reason: str) -> bool:
        self.last_failure = reason
        self.error(reason)
        return False

    def _plan_locked(self) -> bool:
        self.last_failure = ""
        try:
            task = self.build_task()
            task.setSceneProvider(self.fetch_scene)
            timeout = float(self.params.get("planning_timeout"))
            if timeout > 0:
                task.setTimeout(timeout)
        except (TaskError, PlanningError, ValueError) as exc:
            return self._fail(f"building the task failed: {exc}")
        self.task = task
        self.info(f"Starting task planning: '{task.name}'")
        task.addTaskCallback(self._progress_reporter())
        try:
            code = task.plan(int(self.params.get("max_solutions")))
        except InitStageException as exc:
            return self._fail(f"InitStageException caught during task planning: {exc}")
        except (TaskError, PlanningError, ValueError) as exc:
            return self._fail(f"task planning failed: {exc}")
        solved = bool(task.solutions)
        if solved:
            self.info("Task planning completed successfully" + ("" if code else f" ({code.name}: {code.message})"))
            self.info(f"Found {task.numSolutions()} solutions in {task.planning_time:.4f} s")
            self.info("Task state:\n" + task.printState(stream=None).rstrip("\n"))
            self.info("Solutions (cheapest first):\n" + "\n".join(solution_lines(task)))
        else:
            self.error(f"Task planning failed with error code: {code.val} ({code.name}): {code.message}")
            self.error("Task state:\n" + task.printState(stream=None).rstrip("\n"))
            explanation = task.explainFailure(stream=None)
            self.error("Failure explanation:\n" + explanation)
            stages = [line.strip() for line in explanation.splitlines()[1:] if line.strip()]
            self.last_failure = f"{code.name}: {code.message}" if code.message else code.name
            if stages:
                self.last_failure += "; failing stage(s): " + " | ".join(stages[:3])
        self.info("Stage summary:\n" + "\n".join(stage_summary_lines(task)))
        self._publish(task)
        return solved

    def _progress_reporter(self) -> Callable[[Task], None]:
        """A task callback that, at most every PROGRESS_PERIOD while the task plans, publishes its
        statistics (as MTC's introspection does while planning) and logs how far it got."""
        started = time.monotonic()
        last = [started, started]  # last statistics, last log line

        def report(task: Task) -> None:
            now = time.monotonic()
            if now - last[0] < PROGRESS_PERIOD:
                return
            last[0] = now
            try:
                self.introspection.publish_statistics(task.statistics())
            except Exception as exc:  # a report must never break the planning it reports on
                self.warning(f"publishing planning progress failed: {type(exc).__name__}: {exc}")
                return
            if now - last[1] >= PROGRESS_LOG_PERIOD:
                last[1] = now
                self.info(f"planning '{task.name}': {task.numSolutions()} solutions so far after "
                          f"{now - started:.1f} s")

        return report

    def _publish(self, task: Task) -> None:
        try:
            self.introspection.publish_description(task.description())
            self.introspection.publish_statistics(task.statistics())
            if task.solutions:
                self.introspection.publish_solution(task.to_msg(), task.solutions[0].id)
                trajectory = display_trajectory(task)
                self._display_pub.publish(joint_trajectory_to_msg(trajectory, self.get_clock().now().to_msg()))
                self.info(f"Published solution ({len(trajectory.points)} trajectory points on /planned_path)")
        except (TaskError, MessageError, ValueError) as exc:
            self.error(f"publishing the task failed: {exc}")

    # ------------------------------------------------------------------ execution
    def execute(self) -> MoveItErrorCode:
        """Execute the best solution of the last plan through the planning_server (blocking)."""
        with self._lock:
            return self._execute_locked()

    def _execute_locked(self) -> MoveItErrorCode:
        task = self.task
        if task is None or not task.solutions:
            code = MoveItErrorCode(MoveItErrorCode.INVALID_MOTION_PLAN, "there is no solution to execute: plan first")
            self.warning(f"execution refused: {code.message}")
            return code
        try:
            msg = task.to_msg()
        except TaskError as exc:
            code = MoveItErrorCode(MoveItErrorCode.INVALID_MOTION_PLAN, str(exc))
            self.error(f"execution refused: {code.message}")
            return code
        if not msg.moves:
            code = MoveItErrorCode(MoveItErrorCode.INVALID_MOTION_PLAN,
                                   f"the best solution of '{task.name}' contains no motion (its steps only reach "
                                   "states), there is nothing to execute")
            self.warning(f"execution refused: {code.message}")
            return code
        duration = msg.motion_duration
        self.info(f"Executing the best solution of '{task.name}' ({len(msg.sub_trajectory)} steps, "
                  f"{duration:.2f} s of motion) through {self.params.get('planning_server')}")
        # MTC's way: the solution goes to move_group's execute_task_solution action
        code = self._task_ros.execute_message(msg, task.solutions[0].id, duration * 2.0 + 30.0 + self.server_timeout,
                                              self.server_timeout)
        if code:
            self.info(f"Execution succeeded: {code.message or code.name}")
        else:
            self.error(f"Execution failed: {code.name}: {code.message}")
        return code

    # ------------------------------------------------------------------ start-up run
    def _start(self) -> None:
        self._start_timer.cancel()
        self.destroy_timer(self._start_timer)
        self._worker = threading.Thread(target=self._run, name=f"{self.get_name()} worker", daemon=True)
        self._worker.start()

    def _run(self) -> None:
        code = 0
        try:
            self.prepare()
            if self._closing.is_set():
                return
            if not self.plan():
                code = EXIT_PLANNING_FAILED
            elif self.params.get("execute") and not self._closing.is_set():
                if not self.execute():
                    code = EXIT_EXECUTION_FAILED
        except Exception as exc:  # keep the node alive for inspection; report the failure
            self.error(f"{self.title} failed: {type(exc).__name__}: {exc}")
            code = EXIT_PLANNING_FAILED
        self.info(f"{self.title} completed" + ("" if code == 0 else f" with failures (exit code {code})"))
        if self.params.get("exit_when_done") and not self._closing.is_set():
            self._exit(code)

    def _exit(self, code: int) -> None:
        """Let subscribers receive the latched topics, then stop the node (run_task_node
        returns ``code``)."""
        self.exit_code = code
        # Latched (transient local) samples reach only subscribers that have discovered this
        # node; a fast task (no planning_server round trip) could otherwise exit before that.
        remaining = float(self.params.get("exit_linger")) - (time.monotonic() - self._created)
        if remaining > 0:
            self._closing.wait(remaining)
        for publisher in self.publishers:
            try:
                publisher.wait_for_all_acked(Duration(seconds=_ACK_TIMEOUT))
            except Exception:  # not supported by the middleware: nothing to wait for
                pass
        rclpy.try_shutdown(context=self.context)

    # ------------------------------------------------------------------ ROS inputs
    def _on_params(self, changed: dict[str, Any]) -> None:
        self.info("parameters set: " + ", ".join(f"{k}={v!r}" for k, v in changed.items()))
        if changed.get("execute") is True:
            threading.Thread(target=self.execute, name=f"{self.get_name()} execute", daemon=True).start()

    def _srv_plan(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success = self.plan()
        task = self.task
        if response.success and task is not None:
            response.message = (f"{task.numSolutions()} solutions, best cost {task.solutions[0].cost:.4f}, "
                                f"planning time {task.planning_time:.3f} s")
        else:
            response.message = f"planning failed: {self.last_failure or 'no solution'}"
        return response

    def _srv_execute(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        code = self.execute()
        response.success = bool(code)
        response.message = f"{code.name}: {code.message}" if code.message else code.name
        return response

    def close(self) -> None:
        """Called by run_node at shutdown: stop planning, wait briefly for the worker."""
        self._closing.set()
        task = self.task
        if task is not None:
            task.preempt()
        if self._worker is not None and self._worker is not threading.current_thread():
            self._worker.join(timeout=2.0)


def run_task_node(factory: Callable[[], TaskNode], args: list[str] | None = None) -> int:
    """run_node for a task node: the exit code is the node's (exit_when_done), or run_node's."""
    holder: list[TaskNode] = []

    def build() -> TaskNode:
        node = factory()
        holder.append(node)
        return node

    code = run_node(build, args)
    if code == 0 and holder and holder[0].exit_code is not None:
        code = holder[0].exit_code
    return code


def main_for(factory: Callable[[], TaskNode]) -> Callable[[list[str] | None], None]:
    """A console-script ``main(args=None)`` for a task node class."""

    def main(args: list[str] | None = None) -> None:
        sys.exit(run_task_node(factory, args))

    return main
