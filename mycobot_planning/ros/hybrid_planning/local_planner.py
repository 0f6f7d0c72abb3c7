"""The local planner component (MoveIt's LocalPlannerComponent, node ``local_planner_component``):
action server ``local_planning_action`` (moveit_msgs/action/LocalPlanner).

While a goal runs, it follows the newest global trajectory (moveit_msgs/MotionPlanResponse on
``global_trajectory``) at ``local_planning_frequency``: each iteration runs MoveIt's SimpleSampler
and ForwardTrajectory (the ROS-free loop of mycobot_planning.core.hybrid_planning.local_planner)
on the arm's ``/joint_states`` and the current planning scene (the planning_server's full
``/monitored_planning_scene``, rebuilt as a core PlanningScene whenever it changes), and
publishes what it decides on the arm controller's ``joint_trajectory`` topic
(trajectory_msgs/JointTrajectory): the next reference, a stop along the path before a collision
ahead, or an empty trajectory (stop where you are). Feedback: "Collision ahead" (once per
blocked path), "Local planner is stuck". The goal succeeds when the arm is at the trajectory's
last point; a cancel brings the arm to rest along its path and answers canceled. A new global
trajectory while a goal runs (a replan) replaces the one being followed.
"""
from __future__ import annotations

import threading
import time
from typing import Any

from moveit_msgs.action import LocalPlanner
from moveit_msgs.msg import MotionPlanResponse, MoveItErrorCodes, PlanningScene as PlanningSceneRos
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryRos

from interfaces_py import names
from interfaces_py.moveit_conversions import planning_scene_from_msg
from interfaces_py.msgs import JointTrajectory
from interfaces_py.ros_conversions import joint_trajectory_to_msg
from interfaces_py.ros_message_reading import ConversionError
from mycobot_planning.core.hybrid_planning import ForwardTrajectory
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.ros.action_servers import ABORTED, CANCELED, SUCCEEDED
from mycobot_planning.ros.hybrid_planning.component import HybridPlanningComponent
from mycobot_planning.ros.move_group.moveit_translation import joint_trajectory_from_ros
from mycobot_planning.ros.node_runtime import ParameterSpec, Parameters
from mycobot_planning.ros.node_waiter import NodeWaiter
from mycobot_planning.ros.robot_model_loader import load_robot_model

__all__ = ["LocalPlannerComponent"]

LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
INPUT_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: s a goal waits for its global trajectory, and for /joint_states, before it is aborted
INPUT_TIMEOUT = 5.0


def _one_of(name: str, allowed: tuple[str, ...]) -> Any:
    def check(value: Any) -> str | None:
        return None if value in allowed else f"{name} must be one of {', '.join(allowed)} (got '{value}')"
    return check


class LocalPlannerComponent(HybridPlanningComponent):
    def __init__(self, node_name: str = "local_planner_component", **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._params = Parameters(self, [
            ParameterSpec("group_name", "arm", "planning group whose joints the local planner commands",
                          non_empty=True, read_only=True),
            ParameterSpec("local_planning_frequency", 100.0,
                          "Hz of the local planning loop (MoveIt declares 1.0 and its example runs 100.0; "
                          "ours defaults to 100.0 to follow trajectories sampled at 0.01 s)",
                          range=(1.0, 1000.0), read_only=True),
            ParameterSpec("global_solution_topic", "global_trajectory",
                          "moveit_msgs/MotionPlanResponse topic of the global planner's solutions",
                          non_empty=True, read_only=True),
            ParameterSpec("local_solution_topic", "/arm_controller/joint_trajectory",
                          "the arm controller's trajectory_msgs/JointTrajectory command topic",
                          non_empty=True, read_only=True),
            ParameterSpec("local_solution_topic_type", "trajectory_msgs/JointTrajectory",
                          "message type of local_solution_topic (only trajectory_msgs/JointTrajectory: our "
                          "controllers have no Float64MultiArray position controller)", read_only=True,
                          validator=_one_of("local_solution_topic_type", ("trajectory_msgs/JointTrajectory",))),
            ParameterSpec("monitored_planning_scene_topic", names.MONITORED_PLANNING_SCENE,
                          "full moveit_msgs/PlanningScene topic of the planning_server (every change)",
                          non_empty=True, read_only=True),
            ParameterSpec("joint_states_topic", "/joint_states", "the arm's sensor_msgs/JointState topic",
                          non_empty=True, read_only=True),
            ParameterSpec("local_planning_action_name", "local_planning_action",
                          "the LocalPlanner action this component serves", non_empty=True, read_only=True),
            ParameterSpec("trajectory_operator_plugin_name", "moveit_hybrid_planning/SimpleSampler",
                          "trajectory operator (MoveIt's SimpleSampler only)", read_only=True,
                          validator=_one_of("trajectory_operator_plugin_name",
                                            ("moveit_hybrid_planning/SimpleSampler",
                                             "moveit::hybrid_planning/SimpleSampler"))),
            ParameterSpec("local_constraint_solver_plugin_name", "moveit_hybrid_planning/ForwardTrajectory",
                          "local constraint solver (MoveIt's ForwardTrajectory only)", read_only=True,
                          validator=_one_of("local_constraint_solver_plugin_name",
                                            ("moveit_hybrid_planning/ForwardTrajectory",
                                             "moveit::hybrid_planning/ForwardTrajectory"))),
            ParameterSpec("stop_before_collision", True,
                          "ForwardTrajectory: check the path ahead in the current scene and stop the arm before "
                          "a collision (MoveIt declares false; true here)"),
            ParameterSpec("goal_tolerance", 0.01, "rad: every joint this close to the trajectory's last point "
                          "ends the goal successfully", range=(1e-5, 0.5)),
            ParameterSpec("command_lead", 0.05, "s after receipt at which the controller is to reach each "
                          "forwarded reference (longer when the velocity limits need it)", range=(0.005, 1.0)),
        ])
        self._lock = threading.Lock()
        self._model: RobotModel | None = None
        self._trajectory: JointTrajectory | None = None  # a new global trajectory not yet followed
        self._joints: dict[str, float] = {}
        self._velocities: dict[str, float] = {}
        self._joint_stamp = 0  # count of /joint_states messages received
        self._joint_time = 0.0
        self._scene_msg: PlanningSceneRos | None = None
        self._scene_version = 0
        self._active = False
        self._goal_counter = 0
        inputs = MutuallyExclusiveCallbackGroup()
        self.create_subscription(MotionPlanResponse, self._params.get("global_solution_topic"),
                                 self._on_global_trajectory, 1, callback_group=inputs)
        self.create_subscription(JointState, self._params.get("joint_states_topic"), self._on_joint_states,
                                 INPUT_QOS, callback_group=inputs)
        self.create_subscription(PlanningSceneRos, self._params.get("monitored_planning_scene_topic"),
                                 self._on_scene, LATCHED_QOS, callback_group=inputs)
        self._command_pub = self.create_publisher(JointTrajectoryRos, self._params.get("local_solution_topic"), 10)
        self.serve(LocalPlanner, self._params.get("local_planning_action_name"), self._execute,
                   ReentrantCallbackGroup())
        self.get_logger().info(
            f"local planner ready: {self._params.get('local_planning_action_name')} follows "
            f"{self._params.get('global_solution_topic')} at {self._params.get('local_planning_frequency'):g} Hz "
            f"on {self._params.get('local_solution_topic')}")

    # ------------------------------------------------------------------ inputs
    def _on_global_trajectory(self, msg: MotionPlanResponse) -> None:
        if msg.error_code.val != MoveItErrorCodes.SUCCESS:
            return
        try:
            trajectory, _ = joint_trajectory_from_ros(msg.trajectory)
        except ConversionError as exc:
            self.get_logger().warning(f"ignored a global trajectory: {exc.message}")
            return
        with self._lock:
            self._trajectory = trajectory

    def _on_joint_states(self, msg: JointState) -> None:
        with self._lock:
            self._joints.update(zip(msg.name, msg.position))
            if len(msg.velocity) == len(msg.name):
                self._velocities.update(zip(msg.name, msg.velocity))
            self._joint_stamp += 1
            self._joint_time = time.monotonic()

    def _on_scene(self, msg: PlanningSceneRos) -> None:
        with self._lock:
            self._scene_msg = msg
            self._scene_version += 1

    # ------------------------------------------------------------------ the action
    def _finish(self, goal_handle: Any, code: int, message: str, how: str) -> LocalPlanner.Result:
        result = LocalPlanner.Result(error_message=message)
        result.error_code = MoveItErrorCodes(val=code, message=message, source="local_planner_component")
        return self.end(goal_handle, result, how, f"local planning aborted: {message}")

    def _robot_model(self) -> RobotModel:
        if self._model is None:
            self._model = load_robot_model(NodeWaiter(self))
        return self._model

    def _wait_for(self, what: str, ready: Any, goal_handle: Any) -> bool:
        """Whether ``ready()`` came true within INPUT_TIMEOUT (not when canceled or going down)."""
        deadline = time.monotonic() + INPUT_TIMEOUT
        while not ready():
            if goal_handle.is_cancel_requested or self.going_down() or time.monotonic() > deadline:
                return False
            time.sleep(0.01)
        return True

    def _publish(self, command: JointTrajectory) -> None:
        self._command_pub.publish(joint_trajectory_to_msg(command))

    def _execute(self, goal_handle: Any) -> LocalPlanner.Result:
        with self._lock:
            if self._active:
                busy = True
            else:
                busy, self._active = False, True
        if busy:
            return self._finish(goal_handle, MoveItErrorCodes.FAILURE, "another local planning goal is running",
                                ABORTED)
        try:
            return self.answer_always(
                goal_handle, self._run, LocalPlanner.Result, "local planning",
                lambda exc: self._finish(goal_handle, MoveItErrorCodes.FAILURE,
                                         f"internal error ({type(exc).__name__}: {exc})", ABORTED))
        finally:
            with self._lock:
                self._active = False
                self._trajectory = None

    def _run(self, goal_handle: Any) -> LocalPlanner.Result:
        try:
            model = self._robot_model()
        except (ValueError, TimeoutError) as exc:
            return self._finish(goal_handle, MoveItErrorCodes.FAILURE, f"no robot model: {exc}", ABORTED)
        group = self._params.get("group_name")
        if not model.has_group(group):
            return self._finish(goal_handle, MoveItErrorCodes.INVALID_GROUP_NAME,
                                f"group_name '{group}' is not a group of robot '{model.name}'", ABORTED)
        topic = self._params.get("global_solution_topic")
        if not self._wait_for("trajectory", lambda: self._trajectory is not None, goal_handle):
            if goal_handle.is_cancel_requested:
                return self._finish(goal_handle, MoveItErrorCodes.PREEMPTED, "canceled", CANCELED)
            return self._finish(goal_handle, MoveItErrorCodes.FAILURE,
                                f"no global trajectory on {topic} within {INPUT_TIMEOUT:g} s", ABORTED)
        if not self._wait_for("joint states", lambda: self._joint_stamp > 0, goal_handle):
            return self._finish(goal_handle, MoveItErrorCodes.ROBOT_STATE_STALE,
                                f"no {self._params.get('joint_states_topic')} within {INPUT_TIMEOUT:g} s", ABORTED)
        period = 1.0 / float(self._params.get("local_planning_frequency"))
        solver: ForwardTrajectory | None = None
        scene: PlanningScene | None = None
        scene_version = -1
        seen_stamp = -1
        next_time = time.monotonic()
        while True:
            with self._lock:
                trajectory, self._trajectory = self._trajectory, None
                joints, velocities = dict(self._joints), dict(self._velocities)
                stamp, joint_time = self._joint_stamp, self._joint_time
                scene_msg, version = self._scene_msg, self._scene_version
            now = time.monotonic()
            if self.going_down():  # the controller finishes the last command (the reference, 0.05 s ahead)
                return LocalPlanner.Result()
            if goal_handle.is_cancel_requested:
                if solver is not None:
                    stop = solver.stop(joints, velocities)
                    if stop is not None:
                        self._publish(stop)
                return self._finish(goal_handle, MoveItErrorCodes.PREEMPTED, "local planning canceled: the arm "
                                    "is brought to rest along its path", CANCELED)
            if now - joint_time > INPUT_TIMEOUT:
                if solver is not None:
                    self._publish(solver.halt())
                return self._finish(goal_handle, MoveItErrorCodes.ROBOT_STATE_STALE,
                                    f"no {self._params.get('joint_states_topic')} for {INPUT_TIMEOUT:g} s", ABORTED)
            if trajectory is not None:
                problem = self._check_trajectory(model, group, trajectory, joints)
                if problem:
                    if solver is not None:
                        self._publish(solver.halt())
                    return self._finish(goal_handle, MoveItErrorCodes.INVALID_MOTION_PLAN, problem, ABORTED)
                self._goal_counter += 1
                solver = ForwardTrajectory(model, trajectory, period, bool(self._params.get("stop_before_collision")),
                                           float(self._params.get("goal_tolerance")),
                                           float(self._params.get("command_lead")),
                                           goal_id=f"local_planner#{self._goal_counter}")
                self.get_logger().info(f"following a global trajectory of {solver.timed.duration:.2f} s")
            if scene_msg is not None and version != scene_version:
                scene_version = version
                try:
                    scene = PlanningScene.from_msg(model, planning_scene_from_msg(scene_msg))
                except Exception as exc:  # a scene we cannot read: keep the last one
                    self.get_logger().warning(f"ignored a planning scene: {exc}")
                else:
                    variables = set(model.variable_names)
                    scene.set_current_state({n: v for n, v in joints.items() if n in variables})
                    solver.scene_changed()
            out = solver.step(joints, now, scene, fresh=stamp != seen_stamp, velocities=velocities)
            seen_stamp = stamp
            if out.trajectory is not None:
                self._publish(out.trajectory)
            if out.feedback:
                self.get_logger().info(f"feedback: {out.feedback}")
                goal_handle.publish_feedback(LocalPlanner.Feedback(feedback=out.feedback))
            if out.done:
                return self._finish(goal_handle, MoveItErrorCodes.SUCCESS, "", SUCCEEDED)
            next_time += period
            delay = next_time - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                next_time = time.monotonic()

    @staticmethod
    def _check_trajectory(model: RobotModel, group: str, trajectory: JointTrajectory,
                          joints: dict[str, float]) -> str | None:
        joint_names = set(model.group(group).joint_names)
        outside = [n for n in trajectory.joint_names if n not in joint_names]
        if outside:
            return f"the global trajectory moves joints outside group '{group}': {outside}"
        missing = [n for n in trajectory.joint_names if n not in joints]
        if missing:
            return f"no joint state for {missing}"
        return None
