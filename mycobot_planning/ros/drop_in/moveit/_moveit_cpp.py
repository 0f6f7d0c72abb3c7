"""MoveItPy (MoveItCpp's Python face) and its planning scene monitor, on rclpy and our core.

MoveItPy makes its node (parameters from ``--params-file`` files, a ``config_dict`` or the
command line, declared from the overrides as MoveItCpp's node does), spins it on a thread of its
own, loads the robot model (the node's ``robot_description`` parameters, else move_group's),
monitors the scene (``/joint_states``, ``/collision_object``, ``/attached_collision_object``,
``/planning_scene`` diffs, as MoveIt's planning scene monitor does by default) and plans in this
process with the core's planning pipelines. Execution goes through move_group's
``/execute_trajectory`` action (the planning_server: the one place that sends trajectories to the
controllers, checked and watched there), after checking the trajectory against this monitor's
scene, which may hold objects move_group does not know. docs/moveit_py.md has the details.
"""
from __future__ import annotations

import contextlib
import time
from typing import Any, Mapping, Sequence

import rclpy
import rclpy.logging
from moveit_msgs.action import ExecuteTrajectory
from moveit_msgs.msg import AttachedCollisionObject as AttachedCollisionObjectRos
from moveit_msgs.msg import CollisionObject as CollisionObjectRos
from moveit_msgs.msg import PlanningScene as PlanningSceneRos
from moveit_msgs.srv import GetPlanningScene
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from interfaces_py import names
from interfaces_py.action_client import ActionClient
from interfaces_py.background_spin import BackgroundSpin
from interfaces_py.moveit_conversions import attached_object_from_msg, planning_scene_from_msg
from interfaces_py.msgs import MoveItErrorCode
from interfaces_py.ros_message_reading import ConversionError, collision_object_from_msg
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.planning_scene.planning_scene_monitor import PlanningSceneMonitor as CoreSceneMonitor
from mycobot_planning.core.planning_scene.planning_scene_monitor import RequestError
from mycobot_planning.core.robot_model.robot_model import RobotModel as CoreRobotModel
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.ros.node_waiter import SERVER_TIMEOUT, NodeWaiter
from mycobot_planning.ros.robot_model_loader import load_robot_model

from ._planning_component import PlanningComponent
from .core.controller_manager import ExecutionStatus
from .core.planning_scene import PlanningScene
from .core.robot_model import RobotModel, robot_model
from .core.robot_state import RobotState
from .core.robot_trajectory import RobotTrajectory
from .utils import create_params_file_from_dict, get_launch_params_filepaths, ros_params_file

__all__ = ["LockedPlanningSceneContextManagerRO", "LockedPlanningSceneContextManagerRW", "MoveItPy",
           "PlanningSceneMonitor"]

_LOGGER = rclpy.logging.get_logger("moveit_py")


class LockedPlanningSceneContextManagerRO:
    """``with monitor.read_only() as scene``: the monitored scene, locked while the block runs."""

    _write = False

    def __init__(self, monitor: "PlanningSceneMonitor") -> None:
        self._monitor = monitor
        self._context: Any = None

    def __enter__(self) -> PlanningScene:
        self._context = self._monitor._core.locked(write=self._write)
        return PlanningScene._wrap(self._context.__enter__())

    def __exit__(self, *exc: Any) -> Any:
        context, self._context = self._context, None
        return context.__exit__(*exc)


class LockedPlanningSceneContextManagerRW(LockedPlanningSceneContextManagerRO):
    """``with monitor.read_write() as scene``: the monitored scene to change, locked meanwhile."""

    _write = True


class PlanningSceneMonitor:
    """MoveIt's planning scene monitor for MoveItPy: the scene of this process, fed by topics."""

    def __init__(self, node: Node, model: CoreRobotModel, name: str = "planning_scene_monitor") -> None:
        self._node = node
        self._name = name
        self._core = CoreSceneMonitor(model, time.monotonic, self._log)
        self._subscriptions: dict[str, Any] = {}
        self._waiter = NodeWaiter(node)

    def _log(self, level: str, text: str) -> None:
        getattr(self._node.get_logger(), {"warning": "warning", "error": "error"}.get(level, "debug"))(text)

    @property
    def name(self) -> str:
        return self._name

    @property
    def core(self) -> CoreSceneMonitor:
        """The core monitor (ROS-free) behind this one."""
        return self._core

    # ------------------------------------------------------------------ locked scenes
    def read_only(self) -> LockedPlanningSceneContextManagerRO:
        return LockedPlanningSceneContextManagerRO(self)

    def read_write(self) -> LockedPlanningSceneContextManagerRW:
        return LockedPlanningSceneContextManagerRW(self)

    # ------------------------------------------------------------------ monitors
    def start_state_monitor(self, joint_states_topic: str = "joint_states",
                            attached_objects_topic: str = "attached_collision_object") -> None:
        self.stop_state_monitor()
        self._subscribe("joint_states", JointState, joint_states_topic, self._on_joint_state, 10)
        self._subscribe("attached", AttachedCollisionObjectRos, attached_objects_topic, self._on_attached, 100)

    def stop_state_monitor(self) -> None:
        self._unsubscribe("joint_states", "attached")

    def start_scene_monitor(self, scene_topic: str = "planning_scene") -> None:
        self._subscribe("scene", PlanningSceneRos, scene_topic, self._on_scene, 100)

    def stop_scene_monitor(self) -> None:
        self._unsubscribe("scene")

    def start_world_geometry_monitor(self, collision_objects_topic: str = "collision_object") -> None:
        self._subscribe("objects", CollisionObjectRos, collision_objects_topic, self._on_collision_object, 100)

    def _subscribe(self, key: str, msg_type: Any, topic: str, callback: Any, depth: int) -> None:
        self._unsubscribe(key)
        self._subscriptions[key] = self._node.create_subscription(msg_type, topic, callback, depth)

    def _unsubscribe(self, *keys: str) -> None:
        for key in keys:
            subscription = self._subscriptions.pop(key, None)
            if subscription is not None:
                self._node.destroy_subscription(subscription)

    def wait_for_current_robot_state(self, wait_time: float = 1.0) -> bool:
        """True once a joint state for every variable arrived (within ``wait_time`` s)."""
        deadline = time.monotonic() + float(wait_time)
        variables = self._core.model.variable_names
        while True:
            positions, age = self._core.joint_positions()
            if positions is not None and all(v in positions for v in variables):
                return True
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.01)

    def request_planning_scene_state(self, service_name: str = names.GET_PLANNING_SCENE_SERVICE) -> bool:
        """Replace the world with the scene another monitor (move_group) serves."""
        client = self._node.create_client(GetPlanningScene, service_name)
        try:
            answer = self._waiter.call(client, GetPlanningScene.Request(), "requesting the planning scene",
                                       SERVER_TIMEOUT)
            self._core.apply_planning_scene(planning_scene_from_msg(answer.scene))
            return True
        except (TimeoutError, ConversionError, RequestError) as exc:
            _LOGGER.error(f"Failed to call service {service_name}: {exc}")
            return False
        finally:
            self._node.destroy_client(client)

    def update_frame_transforms(self) -> None:
        """Nothing to update: frames are the robot's links and the scene's objects, posed on demand."""

    def clear_octomap(self) -> None:
        """Nothing to clear: octomaps are not supported."""

    def new_planning_scene_message(self, scene: PlanningSceneRos) -> bool:
        """Apply a moveit_msgs/PlanningScene (a diff, or a full scene replacing this one)."""
        try:
            self._core.apply_planning_scene(planning_scene_from_msg(scene))
            return True
        except (ConversionError, RequestError) as exc:
            _LOGGER.error(f"planning scene message refused: {exc}")
            return False

    def process_collision_object(self, collision_object_msg: Any, color_msg: Any = None) -> None:
        with self.read_write() as scene:
            scene.apply_collision_object(collision_object_msg, color_msg)

    def process_attached_collision_object(self, attached_collision_object_msg: Any) -> None:
        with self.read_write() as scene:
            scene.process_attached_collision_object(attached_collision_object_msg)

    # ------------------------------------------------------------------ callbacks
    def _on_joint_state(self, msg: JointState) -> None:
        problem = self._core.update_joint_state(list(msg.name), list(msg.position))
        if problem is not None:
            self._node.get_logger().warning(f"ignoring a joint state: {problem}", throttle_duration_sec=5.0)

    def _guarded(self, what: str, change: Any) -> None:
        try:
            change()
        except (ConversionError, RequestError, ValueError) as exc:
            self._node.get_logger().error(f"{what} refused: {exc}")

    def _on_collision_object(self, msg: CollisionObjectRos) -> None:
        self._guarded("collision object", lambda: self._core.apply_collision_objects([collision_object_from_msg(msg)]))

    def _on_attached(self, msg: AttachedCollisionObjectRos) -> None:
        self._guarded("attached collision object",
                      lambda: self._core.apply_attached_collision_object(attached_object_from_msg(msg)))

    def _on_scene(self, msg: PlanningSceneRos) -> None:
        self._guarded("planning scene", lambda: self._core.apply_planning_scene(planning_scene_from_msg(msg)))


def _node_arguments(node_name: str, launch_params_filepaths: Sequence[str], config_dict: Mapping | None,
                    remappings: Mapping[str, str] | None) -> list[str]:
    """The node's --ros-args, as MoveItPy builds them (config_dict wins over the files)."""
    if config_dict is not None:
        arguments = ["--ros-args", "--params-file", create_params_file_from_dict(dict(config_dict), node_name)]
    elif launch_params_filepaths:
        arguments = ["--ros-args"]
        for path in launch_params_filepaths:
            arguments += ["--params-file", ros_params_file(path)]
    else:
        arguments = []
    for key, value in (remappings or {}).items():
        arguments += ([] if arguments else ["--ros-args"]) + ["--remap", f"{key}:={value}"]
    return arguments


class MoveItPy:
    """The main interface of MoveIt's Python API: ``MoveItPy(node_name="moveit_py")``."""

    def __init__(self, node_name: str = "moveit_py", name_space: str = "",
                 launch_params_filepaths: Sequence[str] | None = None, config_dict: Mapping | None = None,
                 provide_planning_service: bool = True, remappings: Mapping[str, str] | None = None) -> None:
        if launch_params_filepaths is None:
            launch_params_filepaths = get_launch_params_filepaths()
        arguments = _node_arguments(node_name, launch_params_filepaths, config_dict, remappings)
        self._initialized_rclpy = False
        if not rclpy.ok():
            rclpy.init(args=arguments)
            self._initialized_rclpy = True
            _LOGGER.info("Initialize rclcpp")
        self._node = Node(node_name, namespace=name_space or None, cli_args=arguments or None,
                          allow_undeclared_parameters=True, automatically_declare_parameters_from_overrides=True)
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self._node)
        self._spin = BackgroundSpin(self._executor, name=f"{node_name} executor")
        self._closed = False
        try:
            self._configure(provide_planning_service)
        except BaseException:
            self.shutdown()
            raise

    def _parameter(self, name: str, default: Any) -> Any:
        if self._node.has_parameter(name):
            value = self._node.get_parameter(name).value
            if value is not None:
                return value
        return default

    def _configure(self, provide_planning_service: bool) -> None:
        ns = "planning_scene_monitor_options."
        monitor_name = str(self._parameter(ns + "name", "planning_scene_monitor"))
        description = str(self._parameter(ns + "robot_description", "robot_description"))
        wait = float(self._parameter(ns + "wait_for_initial_state_timeout", 0.0))
        try:
            model = load_robot_model(NodeWaiter(self._node), description)
        except (TimeoutError, ValueError) as exc:
            raise RuntimeError("Unable to construct robot model. Please make sure all needed information is on the "
                               f"parameter server ({exc}).") from None
        self._model = model
        self._monitor = PlanningSceneMonitor(self._node, model, monitor_name)
        _LOGGER.info("Listening to 'joint_states' for joint states")
        self._monitor.start_state_monitor()
        self._monitor.start_scene_monitor()
        self._monitor.start_world_geometry_monitor()
        if wait > 0.0 and not self._monitor.wait_for_current_robot_state(wait):
            raise RuntimeError(f"Unable to configure planning scene monitor: no complete joint state on "
                               f"/joint_states within {wait:g} s")
        self._pipelines = self._load_pipelines()
        self._execute_client = ActionClient(self._node, ExecuteTrajectory, names.EXECUTE_TRAJECTORY_ACTION)
        if provide_planning_service:
            _LOGGER.debug("not offering a get_planning_scene service: move_group (the planning_server) offers it")

    def _load_pipelines(self) -> dict[str, PlanningPipeline]:
        """planning_pipelines.pipeline_names: the ones the core has (the others are logged and
        answer "No planning pipeline available"). Without the parameter, all of the core's."""
        requested = self._parameter("planning_pipelines.pipeline_names", None)
        shared = PlanningPipeline()
        known = shared.pipeline_ids  # every registered planner (core.planning_interface.planner_manager)
        if not requested:
            requested = list(known)
            _LOGGER.info(f"planning_pipelines.pipeline_names is not set: loading {requested}")
        loaded = {}
        for name in requested:
            if name in known:
                loaded[str(name)] = shared
            else:
                _LOGGER.error(f"Failed to load planning pipeline '{name}': not one of the pipelines here "
                              f"({', '.join(known)})")
        if not loaded:
            raise RuntimeError("Failed to load planning pipelines from parameter server")
        return loaded

    # ------------------------------------------------------------------ moveit_py's API
    @property
    def node(self) -> Node:
        """The rclpy node MoveItPy made (its parameters are the configuration)."""
        return self._node

    @property
    def planning_pipelines(self) -> dict[str, PlanningPipeline]:
        return dict(self._pipelines)

    def get_robot_model(self) -> RobotModel:
        return robot_model(self._model)

    def get_planning_scene_monitor(self) -> PlanningSceneMonitor:
        return self._monitor

    def get_planning_component(self, planning_component_name: str) -> PlanningComponent:
        return PlanningComponent(planning_component_name, self)

    def get_trajectory_execution_manager(self) -> None:
        raise NotImplementedError("trajectory execution runs in move_group (the planning_server) here: "
                                  "use MoveItPy.execute(trajectory, controllers=[])")

    def current_state(self, wait: float = 1.0) -> RobotState | None:
        """A copy of the current state once joint states are fresh (None after ``wait`` s)."""
        problem = self._monitor.core.joint_state_problem(self._model.variable_names[:1])
        if problem is not None and not self._monitor.wait_for_current_robot_state(wait):
            return None
        return RobotState._wrap(self._monitor.core.scene_copy().current_state)

    def execute(self, robot_trajectory: RobotTrajectory, controllers: Sequence[str] = (),
                blocking: bool = True) -> ExecutionStatus:
        """Execute the trajectory through move_group's execute_trajectory action (the group comes
        with it) and wait until it ends. It is first checked in this monitor's scene (collisions
        along the path, joint limits): a trajectory that fails is not sent (ABORTED)."""
        if robot_trajectory is None or not isinstance(robot_trajectory, RobotTrajectory) or not len(robot_trajectory):
            _LOGGER.error("Robot trajectory is undefined")
            return ExecutionStatus(MoveItErrorCode(MoveItErrorCode.INVALID_MOTION_PLAN, "no trajectory to execute"))
        group = robot_trajectory.joint_model_group_name
        timed = robot_trajectory.timed_trajectory
        scene = self._monitor.core.scene_copy()
        start = robot_trajectory.start_state.copy()
        start.set_joint_positions(dict(zip(timed.joint_names, timed.positions[0])))
        scene.set_current_state(start)
        report = validate_trajectory(scene, timed, group, start)
        if not report.valid:
            message = "; ".join(report.problems[:3])
            _LOGGER.error(f"Execution refused: the trajectory is not valid in the current planning scene: {message}")
            return ExecutionStatus(MoveItErrorCode(MoveItErrorCode.INVALID_MOTION_PLAN, message, "moveit_py"))
        goal = ExecuteTrajectory.Goal()
        goal.trajectory = robot_trajectory.get_robot_trajectory_msg()
        goal.controller_names = [str(c) for c in controllers]
        return self._send(goal, timed.duration)

    def _send(self, goal: Any, duration: float) -> ExecutionStatus:
        result, failure = NodeWaiter(self._node).run_goal(self._execute_client, goal, 2.0 * duration + 30.0,
                                                          SERVER_TIMEOUT, "moveit_py")
        if failure is not None:
            _LOGGER.error(f"Execution failed: {failure.message}")
            return ExecutionStatus(failure)
        code = result.error_code
        status = ExecutionStatus(MoveItErrorCode(code.val, code.message, code.source))
        if status:
            _LOGGER.info(f"Completed trajectory execution with status {status.status}")
        else:
            _LOGGER.error(f"Completed trajectory execution with status {status.status}: {code.message}")
        return status

    def shutdown(self) -> None:
        """Stop spinning, destroy the node, and shut ROS down if MoveItPy started it."""
        if self._closed:
            return
        self._closed = True
        self._spin.stop()
        with contextlib.suppress(Exception):  # best-effort teardown: the context may be gone already
            self._node.destroy_node()
        if self._initialized_rclpy:
            rclpy.try_shutdown()

    def __enter__(self) -> "MoveItPy":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.shutdown()
