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

from typing import Any

from moveit_msgs.msg import PlanningSceneComponents
from moveit_msgs.srv import GetPlanningScene
from moveit_task_constructor_msgs.action import ExecuteTaskSolution
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
from mycobot_planning.ros.node_waiter import SERVER_TIMEOUT, NodeWaiter
from mycobot_planning.ros.robot_model_loader import load_robot_model
from mycobot_planning.ros.task.task_topics import TaskIntrospection

__all__ = ["TaskRosInterface", "MtcIntrospection"]


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
        self._waiter = NodeWaiter(node)
        self._scene_client: Any = None  # created on the first fetch_scene

    # ------------------------------------------------------------------ robot model
    def load_robot_model(self, robot_description: str = "robot_description",
                         timeout: float = SERVER_TIMEOUT) -> RobotModel:
        """MTC's loadRobotModel: the URDF and SRDF (and limits, IK settings) the node or move_group has."""
        return load_robot_model(self._waiter, robot_description, timeout)

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
        answer = self._waiter.call(self._scene_client, request, "reading the current scene",
                                   max(timeout, SERVER_TIMEOUT))
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
        goal = ExecuteTaskSolution.Goal(solution=task_solution_to_msg(msg, solution_id))
        wait = timeout if timeout is not None else 2.0 * msg.motion_duration + 30.0
        result, failure = self._waiter.run_goal(self._execute_client, goal, wait, server_timeout)
        if failure is not None:
            return failure
        code = result.error_code
        return MoveItErrorCode(code.val, code.message, code.source)
