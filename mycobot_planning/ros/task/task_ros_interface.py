"""What a Task does on ROS when a script hands it a node, as MTC's Task does with rclcpp.

MTC's Python scripts call ``task.loadRobotModel(node)``, ``task.publish(solution)`` and
``task.execute(solution)``. The task package is ROS-free, so it loads this module by name (as
pluginlib loads a plugin) the first time it is given a node, and calls :class:`TaskRosInterface`:

* the robot model: the node's own ``robot_description`` parameters if it has them, else those of
  the running ``move_group`` (our planning_server's MoveIt face), with the joint limits and IK
  settings it carries (``robot_description_planning.*``, ``robot_description_kinematics.*``);
* the current scene for CurrentState: move_group's ``/get_planning_scene``;
* introspection: MTC's topics (``/description``, ``/statistics``, ``/solution``) and our task
  viewer's (``<node>/task/...``), through ros.task.task_topics.TaskIntrospection;
* execution: move_group's ``/execute_task_solution`` action, as MTC's Task::execute.

The script's node usually is not spinning: each call spins it until its answer arrives. A node
that an executor already spins (another thread) is only waited on.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import rclpy
import rclpy.parameter
from moveit_msgs.msg import PlanningSceneComponents
from moveit_msgs.srv import GetPlanningScene
from moveit_task_constructor_msgs.action import ExecuteTaskSolution
from rcl_interfaces.srv import GetParameters, ListParameters
from rclpy.node import Node

from interfaces_py import names
from interfaces_py.action_client import ActionClient
from interfaces_py.moveit_conversions import ConversionError, planning_scene_from_msg
from interfaces_py.msgs import MessageError, MoveItErrorCode, TaskSolution
from interfaces_py.msgs import PlanningScene as PlanningSceneMsg
from interfaces_py.mtc_conversions import task_solution_to_msg
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.ros.task.task_topics import TaskIntrospection
from mycobot_planning.paths import package_share_dirs

__all__ = ["TaskRosInterface", "MtcIntrospection", "parameter_tree"]

#: s to wait for move_group's parameters, scene and action server
SERVER_TIMEOUT = 10.0
PLANNING_PREFIX = "robot_description_planning"
KINEMATICS_PREFIX = "robot_description_kinematics"


def parameter_tree(flat: dict[str, Any], prefix: str) -> dict[str, Any]:
    """``{"a.b.c": 1}`` under ``prefix`` "a" -> ``{"b": {"c": 1}}`` (how ROS 2 flattens YAML)."""
    tree: dict[str, Any] = {}
    for key, value in flat.items():
        if not key.startswith(prefix + "."):
            continue
        node = tree
        *parents, leaf = key[len(prefix) + 1:].split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    return tree


class MtcIntrospection:
    """MTC's Introspection object (``task.introspection``): publishes what the task viewer and
    RViz's Motion Planning Tasks panel show."""

    def __init__(self, topics: TaskIntrospection, task: Any) -> None:
        self._topics = topics
        self._task = task

    def publishTaskDescription(self) -> None:
        self._topics.publish_description(self._task.description())

    def publishTaskState(self) -> None:
        self._topics.publish_statistics(self._task.statistics())

    def publishSolution(self, solution: Any) -> None:
        self._topics.publish_solution(self._task.to_msg(solution), getattr(solution, "id", 0))

    def publishAllSolutions(self, wait: bool = False) -> None:
        for solution in self._task.solutions:
            self.publishSolution(solution)

    def reset(self) -> None:
        """MTC's reset forgets published solutions; here a new description replaces the old."""
        self.publishTaskDescription()


class TaskRosInterface:
    """The ROS side of one Task (see module docstring)."""

    def __init__(self, node: Any, callback_group: Any = None) -> None:
        """``callback_group``: where the action client's answers run (a node that blocks in one of
        its own callbacks needs a reentrant one)."""
        if not isinstance(node, Node):
            raise TypeError(f"expected an rclpy Node, got {type(node).__name__}")
        self.node = node
        self._topics: TaskIntrospection | None = None
        # created now, so that it has found the action server by the time execute() is called
        self._execute_client = ActionClient(node, ExecuteTaskSolution, names.EXECUTE_TASK_SOLUTION_ACTION,
                                            callback_group=callback_group)
        self._spun_by: Any = None  # the executor our own spinning left the node in
        self._scene_client: Any = None  # created on the first fetch_scene

    # ------------------------------------------------------------------ waiting
    def _wait(self, future: Any, timeout: float) -> Any:
        """The future's result once done; spins the node unless an executor already does."""
        executor = self.node.executor
        if executor is None or executor is self._spun_by:
            # (spin_until_future_complete leaves the node's executor set to the one it used)
            rclpy.spin_until_future_complete(self.node, future, timeout_sec=timeout)
            self._spun_by = self.node.executor
        else:
            done = threading.Event()
            future.add_done_callback(lambda _f: done.set())
            done.wait(timeout)
        if not future.done():
            future.cancel()
            raise TimeoutError(f"no answer within {timeout:g} s")
        return future.result()

    def _call(self, client: Any, request: Any, what: str, timeout: float) -> Any:
        started = time.monotonic()
        if not client.wait_for_service(timeout_sec=timeout):
            raise TimeoutError(f"{what}: no server answers on {client.srv_name} within {timeout:g} s "
                               "(is the planning_server running?)")
        try:
            return self._wait(client.call_async(request), max(0.1, timeout - (time.monotonic() - started)))
        except TimeoutError as exc:
            raise TimeoutError(f"{what}: {exc}") from None

    # ------------------------------------------------------------------ robot model
    def _own_parameters(self, names_: list[str]) -> dict[str, Any]:
        out = {}
        for name in names_:
            if self.node.has_parameter(name):
                value = self.node.get_parameter(name).value
                if value not in (None, ""):
                    out[name] = value
        return out

    def _move_group_parameters(self, robot_description: str, timeout: float) -> dict[str, Any]:
        """robot_description(_semantic) and the planning/kinematics trees from move_group."""
        node_name = f"/{names.MOVE_GROUP_NODE}"
        lister = self.node.create_client(ListParameters, f"{node_name}/list_parameters")
        getter = self.node.create_client(GetParameters, f"{node_name}/get_parameters")
        try:
            request = ListParameters.Request(prefixes=[PLANNING_PREFIX, KINEMATICS_PREFIX], depth=0)
            listed = list(self._call(lister, request, "loading the robot model", timeout).result.names)
            wanted = [robot_description, f"{robot_description}_semantic", *listed]
            answer = self._call(getter, GetParameters.Request(names=wanted), "loading the robot model", timeout)
        finally:
            self.node.destroy_client(lister)
            self.node.destroy_client(getter)
        return {name: rclpy.parameter.parameter_value_to_python(value) for name, value in zip(wanted, answer.values)}

    def load_robot_model(self, robot_description: str = "robot_description",
                         timeout: float = SERVER_TIMEOUT) -> RobotModel:
        """MTC's loadRobotModel: the URDF and SRDF (and limits, IK settings) the node or move_group has."""
        params = self._own_parameters([robot_description, f"{robot_description}_semantic"])
        if robot_description not in params:
            params = self._move_group_parameters(robot_description, timeout)
        urdf = params.get(robot_description)
        if not urdf:
            raise ValueError(f"no '{robot_description}' parameter on this node or on /{names.MOVE_GROUP_NODE}")
        srdf = params.get(f"{robot_description}_semantic") or '<robot name=""/>'
        limits = parameter_tree(params, PLANNING_PREFIX) or None
        kinematics = parameter_tree(params, KINEMATICS_PREFIX) or None
        return RobotModel.from_strings(urdf, srdf, limits, kinematics, package_dirs=package_share_dirs())

    # ------------------------------------------------------------------ scene
    def fetch_scene(self, model: RobotModel, timeout: float) -> PlanningScene:
        """move_group's current scene (every component) as a core PlanningScene."""
        request = GetPlanningScene.Request()
        request.components.components = sum(
            getattr(PlanningSceneComponents, c) for c in (
                "SCENE_SETTINGS", "ROBOT_STATE", "ROBOT_STATE_ATTACHED_OBJECTS", "WORLD_OBJECT_NAMES",
                "WORLD_OBJECT_GEOMETRY", "ALLOWED_COLLISION_MATRIX", "OBJECT_COLORS", "TRANSFORMS"))
        if self._scene_client is None:
            self._scene_client = self.node.create_client(GetPlanningScene, names.GET_PLANNING_SCENE_SERVICE)
        answer = self._call(self._scene_client, request, "reading the current scene", max(timeout, SERVER_TIMEOUT))
        try:
            msg = PlanningSceneMsg.from_dict(planning_scene_from_msg(answer.scene))
            if msg.robot_model_name and msg.robot_model_name != model.name:
                raise ValueError(f"move_group plans for robot '{msg.robot_model_name}', the task for '{model.name}'")
            return PlanningScene.from_msg(model, msg)
        except (ConversionError, MessageError, PlanningError) as exc:
            raise ValueError(f"unusable scene from move_group: {exc}") from None

    # ------------------------------------------------------------------ introspection
    def introspection(self, task: Any) -> MtcIntrospection:
        if self._topics is None:
            self._topics = TaskIntrospection(self.node)
        return MtcIntrospection(self._topics, task)

    # ------------------------------------------------------------------ execution
    def execute(self, task: Any, solution: Any, timeout: float | None = None) -> MoveItErrorCode:
        """MTC's Task::execute: the solution to move_group's execute_task_solution action; blocks
        until the motion ended (or ``timeout``, default twice its duration plus 30 s)."""
        return self.execute_message(task.to_msg(solution), getattr(solution, "id", 0), timeout)

    def execute_message(self, msg: TaskSolution, solution_id: int = 0, timeout: float | None = None,
                        server_timeout: float = SERVER_TIMEOUT) -> MoveItErrorCode:
        """A TaskSolution message through execute_task_solution (what task nodes execute, too)."""
        if not self._execute_client.wait_for_server(timeout_sec=server_timeout):
            return MoveItErrorCode(MoveItErrorCode.COMMUNICATION_FAILURE,
                                   f"no execute_task_solution action server answers within {server_timeout:g} s "
                                   "(is the planning_server running?)")
        goal = ExecuteTaskSolution.Goal(solution=task_solution_to_msg(msg, solution_id))
        try:
            handle = self._wait(self._execute_client.send_goal_async(goal), server_timeout)
        except TimeoutError:
            handle = None
        if handle is None or not handle.accepted:
            return MoveItErrorCode(MoveItErrorCode.COMMUNICATION_FAILURE, "the execute_task_solution goal was not accepted")
        wait = timeout if timeout is not None else 2.0 * msg.motion_duration + 30.0
        try:
            result = self._wait(handle.get_result_async(), wait)
        except TimeoutError:
            handle.cancel_goal_async()
            return MoveItErrorCode(MoveItErrorCode.TIMED_OUT, f"execute_task_solution gave no result within {wait:.0f} s")
        code = result.result.error_code
        return MoveItErrorCode(code.val, code.message, code.source)
