"""servo_node: MoveIt Servo's ROS interface (Jazzy's, plus Humble's start/stop services) over the
ROS-free servo computation (mycobot_planning.core.servo).

* parameters: under ``moveit_servo.`` with MoveIt's names and defaults (``ros2 param describe``
  explains each; read-only ones as in MoveIt), see docs/servo.md;
* in: ``~/delta_twist_cmds`` (geometry_msgs/TwistStamped), ``~/delta_joint_cmds``
  (control_msgs/JointJog), ``~/pose_target_cmds`` (geometry_msgs/PoseStamped), ``/joint_states``,
  and the scene move_group monitors, ``/monitored_planning_scene`` (moveit_msgs/PlanningScene,
  full scene on every change): servo reads it and never serves ``/get_planning_scene`` itself;
* out: ``command_out_topic`` (default ``/arm_controller/joint_trajectory``, JointTrajectory or
  Float64MultiArray) every ``publish_period`` while the arm moves, ``~/status``
  (moveit_msgs/ServoStatus) every period;
* services: ``~/switch_command_type`` (moveit_msgs/ServoCommandType), ``~/pause_servo``
  (std_srvs/SetBool), Humble's ``~/start_servo`` / ``~/stop_servo`` (std_srvs/Trigger; after
  start_servo the command type follows the topic a command arrives on, as Humble's servo took
  twists and joint jogs alike).

The loop runs in a thread of its own at ``publish_period`` (sleeping to absolute deadlines; SCHED_FIFO
at ``thread_priority`` when the system allows it, as MoveIt's); the collision monitor in another at
``collision_check_rate`` with a scene copy of its own.
"""
from __future__ import annotations

import math
import os
import threading
import time
from typing import Any

import numpy as np
from control_msgs.msg import JointJog
from geometry_msgs.msg import PoseStamped, TwistStamped
from moveit_msgs.msg import PlanningScene as PlanningSceneMsg, ServoStatus
from moveit_msgs.srv import ServoCommandType
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from interfaces_py import names
from interfaces_py.moveit_conversions import ConversionError, planning_scene_from_msg
from interfaces_py.ros_conversions import seconds_to_duration
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.servo import (
    CommandError,
    CommandType,
    JointJogCommand,
    PoseCommand,
    Servo,
    ServoParameters,
    StatusCode,
    TwistCommand,
    collision_velocity_scale,
)
from mycobot_planning.core.servo.parameters import COMMAND_IN_TYPES, STATUS_MESSAGES
from mycobot_planning.core.transforms import make_pose
from mycobot_planning.ros import fast_log
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.ros.node_waiter import NodeWaiter
from mycobot_planning.ros.robot_model_loader import load_robot_model

P = "moveit_servo."
OUTPUT_TYPES = ("trajectory_msgs/JointTrajectory", "std_msgs/Float64MultiArray")
LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
COMMAND_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: periods at rest after the last command before the servo stops publishing (and re-reads the
#: robot's state on the next command): it must not keep commanding a controller others use
REST_PERIODS = 5
#: s after the arm came to rest (beyond max_expected_latency, which it still needs to arrive) during
#: which a new command goes on from the commanded state; later ones start from the measured state
RESUME_WINDOW = 0.3
#: s between two log lines about the same kind of refused input
LOG_THROTTLE = 1.0


def _one_of(name: str, allowed: tuple[str, ...]):
    return lambda value: None if value in allowed else f"{name} must be one of {list(allowed)}, got '{value}'"


def _margins(value: Any) -> str | None:
    values = list(value)
    if not values or any(not math.isfinite(v) or v < 0 for v in values):
        return "joint_limit_margins must hold one or more finite values >= 0"
    return None


def parameter_specs() -> list[ParameterSpec]:
    """The node's parameters: MoveIt Servo's (servo_parameters.yaml) under ``moveit_servo.``."""
    positive = (1e-9, 1e9)
    return [
        ParameterSpec("robot_description", "", "URDF of the robot; empty: read it from /move_group", read_only=True),
        ParameterSpec("robot_description_semantic", "", "SRDF of the robot; empty: read it from /move_group",
                      read_only=True),
        ParameterSpec(P + "thread_priority", 40, "SCHED_FIFO priority of the servo loop thread (as MoveIt's; "
                      "0: normal scheduling; without the right to it, normal scheduling and a warning)",
                      range=(0, 99), read_only=True),
        ParameterSpec(P + "move_group_name", "arm", "planning group to servo", non_empty=True, read_only=True),
        ParameterSpec(P + "active_subgroup", "", "subgroup to servo (only the group itself or empty is supported)"),
        ParameterSpec(P + "publish_period", 0.01, "s between two servo loop iterations (and commands out)",
                      range=(0.001, 1.0), read_only=True),
        ParameterSpec(P + "max_expected_latency", 0.1, "s ahead of now the commanded point is stamped "
                      "(time_from_start of the trajectory point)", range=(0.001, 5.0), read_only=True),
        ParameterSpec(P + "incoming_command_timeout", 0.1, "s after the last command before the arm is "
                      "brought to rest", range=positive),
        ParameterSpec(P + "command_in_type", "unitless", "unitless (commands in [-1, 1], times the scale.* "
                      "parameters) or speed_units (m/s, rad/s)", validator=_one_of("command_in_type", COMMAND_IN_TYPES)),
        ParameterSpec(P + "scale.linear", 0.4, "m/s of a unitless 1.0 twist (speed_units: the most allowed)", range=positive),
        ParameterSpec(P + "scale.rotational", 0.8, "rad/s of a unitless 1.0 twist (speed_units: the most allowed)",
                      range=positive),
        ParameterSpec(P + "scale.joint", 0.5, "rad/s of a unitless 1.0 joint jog", range=positive),
        ParameterSpec(P + "apply_twist_commands_about_ee_frame", True, "twists rotate about the end effector "
                      "(their axes are the command frame's); false: about the command frame's origin"),
        ParameterSpec(P + "pose_tracking.linear_tolerance", 0.001, "m: a pose target is reached within this",
                      range=positive),
        ParameterSpec(P + "pose_tracking.angular_tolerance", 0.01, "rad: a pose target is reached within this",
                      range=positive),
        ParameterSpec(P + "pose_command_in_topic", "~/pose_target_cmds", "PoseStamped commands in",
                      non_empty=True, read_only=True),
        ParameterSpec(P + "cartesian_command_in_topic", "~/delta_twist_cmds", "TwistStamped commands in",
                      non_empty=True, read_only=True),
        ParameterSpec(P + "joint_command_in_topic", "~/delta_joint_cmds", "JointJog commands in",
                      non_empty=True, read_only=True),
        ParameterSpec(P + "status_topic", "~/status", "ServoStatus out, every period", non_empty=True, read_only=True),
        ParameterSpec(P + "command_out_topic", "/arm_controller/joint_trajectory", "joint commands out",
                      non_empty=True, read_only=True),
        ParameterSpec(P + "command_out_type", OUTPUT_TYPES[0], "trajectory_msgs/JointTrajectory or "
                      "std_msgs/Float64MultiArray", read_only=True, validator=_one_of("command_out_type", OUTPUT_TYPES)),
        ParameterSpec(P + "publish_joint_positions", True, "put positions in the commands out"),
        ParameterSpec(P + "publish_joint_velocities", True, "put velocities in the commands out"),
        ParameterSpec(P + "publish_joint_accelerations", False, "put accelerations in the commands out"),
        ParameterSpec(P + "monitored_planning_scene_topic", names.MONITORED_PLANNING_SCENE,
                      "full planning scenes from move_group (collision checking)", non_empty=True, read_only=True),
        ParameterSpec(P + "joint_topic", "/joint_states", "the robot's joint states", non_empty=True, read_only=True),
        ParameterSpec(P + "check_octomap_collisions", False, "octomaps are not supported (must stay false)",
                      read_only=True, validator=lambda v: "octomaps are not supported" if v else None),
        ParameterSpec(P + "is_primary_planning_scene_monitor", False, "accepted for MoveIt compatibility; "
                      "servo_node never serves /get_planning_scene (move_group owns the scene)", read_only=True),
        ParameterSpec(P + "use_smoothing", True, "smooth the commands with the Butterworth filter", read_only=True),
        ParameterSpec(P + "smoothing_filter_plugin_name", "online_signal_smoothing::ButterworthFilterPlugin",
                      "only the Butterworth filter is provided", read_only=True,
                      validator=_one_of("smoothing_filter_plugin_name",
                                        ("online_signal_smoothing::ButterworthFilterPlugin",))),
        ParameterSpec(P + "online_signal_smoothing.butterworth_filter_coeff", 1.5, "Butterworth coefficient "
                      "(> 1; larger is smoother and slower)", range=(1.000001, 1e6)),
        ParameterSpec(P + "check_collisions", True, "slow down and halt near collisions"),
        ParameterSpec(P + "collision_check_rate", 10.0, "Hz of the collision monitor", range=(0.1, 1000.0)),
        ParameterSpec(P + "self_collision_proximity_threshold", 0.01, "m: slow down below this self distance",
                      range=positive),
        ParameterSpec(P + "scene_collision_proximity_threshold", 0.02, "m: slow down below this distance to "
                      "the scene", range=positive),
        ParameterSpec(P + "lower_singularity_threshold", 17.0, "Jacobian condition number where slowing "
                      "down starts", range=positive),
        ParameterSpec(P + "hard_stop_singularity_threshold", 30.0, "condition number where the arm halts "
                      "(moving toward the singularity)", range=positive),
        ParameterSpec(P + "leaving_singularity_threshold_multiplier", 2.0, "widens the slow-down band when "
                      "moving away from a singularity", range=positive),
        ParameterSpec(P + "singularity_step_scale", 0.01, "probe step telling toward from away", range=positive),
        ParameterSpec(P + "joint_limit_margins", [0.1], "rad kept from each joint limit (one value, or one per "
                      "joint)", validator=_margins),
        ParameterSpec(P + "halt_all_joints_in_joint_mode", True, "a joint at its limit halts every joint (joint jog)"),
        ParameterSpec(P + "halt_all_joints_in_cartesian_mode", True, "a joint at its limit halts every joint "
                      "(twist, pose)"),
        ParameterSpec(P + "override_velocity_scaling_factor", 0.0, "fixed velocity scaling in [0, 1]; 0: "
                      "internal scaling", range=(0.0, 1.0)),
    ]


class ServoNode(Node):
    """See the module docstring."""

    def __init__(self) -> None:
        super().__init__("servo_node")
        self._params = Parameters(self, parameter_specs())
        values = self._params.values()
        self.model = load_robot_model(NodeWaiter(self))
        servo_params = self._servo_parameters(values)
        self.servo = Servo(self.model, servo_params)  # ValueError: bad group / parameters
        if values[P + "active_subgroup"] not in ("", servo_params.move_group_name):
            raise ValueError("active_subgroup: only the move_group_name group itself (or empty) is supported")
        self._lock = threading.RLock()  # the step (under it) calls _collides (which takes it)
        self._throttle = fast_log.Throttle(LOG_THROTTLE)
        self._period = float(values[P + "publish_period"])
        self._latency = float(values[P + "max_expected_latency"])
        self._thread_priority = int(values[P + "thread_priority"])
        self._joint_names = list(self.servo.joint_names)
        self._output_is_trajectory = values[P + "command_out_type"] == OUTPUT_TYPES[0]
        self._flags = {k: v for k, v in values.items() if k.startswith(P + "publish_joint_")}
        # robot state and scene
        self._measured: np.ndarray | None = None
        self._variables = {name: i for i, name in enumerate(self.model.variable_names)}
        self._js_names: tuple[str, ...] = ()
        self._js_index = np.zeros(0, dtype=int)
        self._measured_received = False
        self._scene_msg: dict | None = None
        self._scene_version = 0
        # commands
        self._command_type: int | None = None
        self._legacy = False  # after start_servo: the command type follows the topic
        #: system time of the last resume (pause_servo false, start_servo): commands stamped before it
        #: were sent while the servo was paused and never act, however late they are delivered
        self._resumed_at = 0.0
        self._paused = False
        self._latest: dict[int, tuple[Any, float]] = {}
        self._invalid: str | None = None
        # loop state
        self._synced = False
        self._rest_periods = 0
        self._collision = (1.0, StatusCode.NO_WARNING)
        self._nearest = ""
        self._loop_scene: PlanningScene | None = None
        self._loop_scene_version = -1
        self._loop_state = RobotState(self.model)
        self._running = True
        self._wake = threading.Event()
        self.loop_iterations = 0

        inputs = MutuallyExclusiveCallbackGroup()
        services = MutuallyExclusiveCallbackGroup()
        state_group = MutuallyExclusiveCallbackGroup()
        self.create_subscription(TwistStamped, values[P + "cartesian_command_in_topic"], self._on_twist,
                                 COMMAND_QOS, callback_group=inputs)
        self.create_subscription(JointJog, values[P + "joint_command_in_topic"], self._on_joint_jog,
                                 COMMAND_QOS, callback_group=inputs)
        self.create_subscription(PoseStamped, values[P + "pose_command_in_topic"], self._on_pose,
                                 COMMAND_QOS, callback_group=inputs)
        self.create_subscription(JointState, values[P + "joint_topic"], self._on_joint_state, 10,
                                 callback_group=state_group)
        self.create_subscription(PlanningSceneMsg, values[P + "monitored_planning_scene_topic"], self._on_scene,
                                 LATCHED_QOS, callback_group=state_group)
        self._status_pub = self.create_publisher(ServoStatus, values[P + "status_topic"], 10)
        if self._output_is_trajectory:
            self._out_pub = self.create_publisher(JointTrajectory, values[P + "command_out_topic"], 10)
        else:
            self._out_pub = self.create_publisher(Float64MultiArray, values[P + "command_out_topic"], 10)
        self.create_service(ServoCommandType, "~/switch_command_type", self._srv_switch, callback_group=services)
        self.create_service(SetBool, "~/pause_servo", self._srv_pause, callback_group=services)
        self.create_service(Trigger, "~/start_servo", self._srv_start, callback_group=services)
        self.create_service(Trigger, "~/stop_servo", self._srv_stop, callback_group=services)
        self._params.on_change(self._on_params)
        self.add_on_set_parameters_callback(self._check_together)

        # As MoveIt's servo node: SCHED_FIFO at thread_priority, set in the constructor, so the
        # threads started from here on (the loop, the collision monitor, run_node's executor)
        # inherit it. The loop takes thread_priority, the others one below: a thread holding the GIL
        # the loop needs must not be preempted by ordinary processes (a priority inversion of up
        # to a scheduler time slice, several ms on a loaded machine), nor delay the loop itself.
        self._realtime = self._thread_priority > 0 and self._schedule_fifo(max(1, self._thread_priority - 1))
        if self._realtime:
            self.get_logger().info(f"SCHED_FIFO: servo loop thread at priority {self._thread_priority}, the "
                                   f"node's other threads at {max(1, self._thread_priority - 1)}")
        self._loop_thread = threading.Thread(target=self._loop, name="servo loop", daemon=True)
        self._collision_thread = threading.Thread(target=self._collision_loop, name="servo collision monitor",
                                                  daemon=True)
        self._loop_thread.start()
        self._collision_thread.start()
        self.get_logger().info(
            f"servo_node ready: group '{self.servo.group.name}' ({len(self._joint_names)} joints, tip "
            f"'{self.servo.tip}'), {1.0 / self._period:g} Hz to {values[P + 'command_out_topic']} "
            f"({values[P + 'command_out_type']}); call ~/switch_command_type (or ~/start_servo) to accept commands")

    # ------------------------------------------------------------------ parameters
    def _servo_parameters(self, v: dict[str, Any]) -> ServoParameters:
        return ServoParameters(
            move_group_name=v[P + "move_group_name"],
            publish_period=float(v[P + "publish_period"]),
            max_expected_latency=float(v[P + "max_expected_latency"]),
            incoming_command_timeout=float(v[P + "incoming_command_timeout"]),
            command_in_type=v[P + "command_in_type"],
            scale_linear=float(v[P + "scale.linear"]),
            scale_rotational=float(v[P + "scale.rotational"]),
            scale_joint=float(v[P + "scale.joint"]),
            apply_twist_commands_about_ee_frame=bool(v[P + "apply_twist_commands_about_ee_frame"]),
            pose_tracking_linear_tolerance=float(v[P + "pose_tracking.linear_tolerance"]),
            pose_tracking_angular_tolerance=float(v[P + "pose_tracking.angular_tolerance"]),
            check_collisions=bool(v[P + "check_collisions"]),
            collision_check_rate=float(v[P + "collision_check_rate"]),
            self_collision_proximity_threshold=float(v[P + "self_collision_proximity_threshold"]),
            scene_collision_proximity_threshold=float(v[P + "scene_collision_proximity_threshold"]),
            lower_singularity_threshold=float(v[P + "lower_singularity_threshold"]),
            hard_stop_singularity_threshold=float(v[P + "hard_stop_singularity_threshold"]),
            leaving_singularity_threshold_multiplier=float(v[P + "leaving_singularity_threshold_multiplier"]),
            singularity_step_scale=float(v[P + "singularity_step_scale"]),
            joint_limit_margins=[float(m) for m in v[P + "joint_limit_margins"]],
            halt_all_joints_in_joint_mode=bool(v[P + "halt_all_joints_in_joint_mode"]),
            halt_all_joints_in_cartesian_mode=bool(v[P + "halt_all_joints_in_cartesian_mode"]),
            override_velocity_scaling_factor=float(v[P + "override_velocity_scaling_factor"]),
            butterworth_filter_coeff=float(v[P + "online_signal_smoothing.butterworth_filter_coeff"]),
            use_smoothing=bool(v[P + "use_smoothing"]),
        )

    def _check_together(self, params: list[Any]) -> SetParametersResult:
        """Refuse a set whose values are fine one by one but not together (e.g. the lower
        singularity threshold above the hard stop), before anything changes."""
        values = self._params.values()
        for param in params:
            if param.name in values:
                value = param.value
                values[param.name] = value.tolist() if hasattr(value, "tolist") else value
        try:
            problems = self._servo_parameters(values).problems(len(self._joint_names))
        except (TypeError, ValueError) as exc:
            problems = [str(exc)]
        if problems:
            reason = "; ".join(problems)
            self.get_logger().warning(f"refused parameters: {reason}")
            return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _on_params(self, changed: dict[str, Any]) -> None:
        self._flags = {k: v for k, v in self._params.values().items() if k.startswith(P + "publish_joint_")}
        try:
            params = self._servo_parameters(self._params.values())
            with self._lock:
                self.servo.set_parameters(params)
        except ValueError as exc:
            # accepted one by one, inconsistent together (e.g. lower above hard stop): keep the old set
            self.get_logger().error(f"servo parameters not applied: {exc}")
            return
        self.get_logger().info(f"servo parameters updated: {sorted(k[len(P):] for k in changed if k.startswith(P))}")

    # ------------------------------------------------------------------ inputs
    def _refuse(self, kind: str, reason: str) -> None:
        with self._lock:
            self._invalid = reason
        if self._throttle(kind + reason[:40]):
            self.get_logger().warning(f"refused {kind} command: {reason}")

    def _accept(self, kind: int, command: Any, stamp: Any = None) -> None:
        with self._lock:
            paused = self._paused
        if paused:
            if self._throttle("paused"):
                self.get_logger().info("ignoring a command sent while servoing was paused")
            return
        with self._lock:
            if self._legacy and kind != CommandType.POSE:
                self._command_type = kind
            current = self._command_type
        if current is None:
            if self._throttle("no type"):
                self.get_logger().warning("Command type has not been set, cannot accept input "
                                          "(call ~/switch_command_type)")
            return
        if current != kind:
            if self._throttle(f"type {kind}"):
                self.get_logger().warning(f"ignoring a {CommandType.NAMES[kind]} command: the command type is "
                                          f"{CommandType.NAMES[current]} (call ~/switch_command_type)")
            return
        try:
            with self._lock:
                self.servo.check_command(command)
        except CommandError as exc:
            self._refuse(CommandType.NAMES[kind].lower(), str(exc))
            return
        received = time.time()
        sent = stamp.sec + stamp.nanosec * 1e-9 if stamp is not None else 0.0
        with self._lock:
            resumed_at = self._resumed_at
        if 0.0 < sent < resumed_at:
            if self._throttle("paused"):
                self.get_logger().info("ignoring a command sent while servoing was paused")
            return
        # as MoveIt: a command is as old as its stamp; unstamped (0) or future ones from when they came
        when = sent if 0.0 < sent <= received else received
        with self._lock:
            self._latest[kind] = (command, when)
            idle = not self._synced
        if idle:
            self._wake.set()  # start now, not at the idle loop's next tick

    def _on_twist(self, msg: TwistStamped) -> None:
        t = msg.twist
        self._accept(CommandType.TWIST, TwistCommand(msg.header.frame_id, (t.linear.x, t.linear.y, t.linear.z),
                                                     (t.angular.x, t.angular.y, t.angular.z)), msg.header.stamp)

    def _on_joint_jog(self, msg: JointJog) -> None:
        if len(msg.displacements) and self._throttle("displacements"):
            self.get_logger().warning("JointJog displacements are not yet supported; using the velocities only")
        self._accept(CommandType.JOINT_JOG, JointJogCommand(tuple(msg.joint_names), tuple(msg.velocities)),
                     msg.header.stamp)

    def _on_pose(self, msg: PoseStamped) -> None:
        p, o = msg.pose.position, msg.pose.orientation
        try:
            pose = make_pose([p.x, p.y, p.z], quat_xyzw=[o.x, o.y, o.z, o.w])
        except ValueError as exc:
            self._refuse("pose", f"bad pose: {exc}")
            return
        if not np.all(np.isfinite(pose)):
            self._refuse("pose", "pose command has a NaN or infinite value")
            return
        self._accept(CommandType.POSE, PoseCommand(msg.header.frame_id, pose), msg.header.stamp)

    def _on_joint_state(self, msg: JointState) -> None:
        names = tuple(msg.name)
        if len(names) != len(msg.position):
            return
        if names != self._js_names:  # where each name goes in the model's variables (-1: not ours)
            self._js_names = names
            self._js_index = np.array([self._variables.get(n, -1) for n in names], dtype=int)
        index = self._js_index
        values = np.asarray(msg.position, dtype=float)
        use = (index >= 0) & np.isfinite(values)
        if not np.any(use):
            return
        with self._lock:
            full = self._measured.copy() if self._measured is not None else self.model.default_positions().astype(float)
            full[index[use]] = values[use]
            self._measured = full
            self._measured_received = True

    def _on_scene(self, msg: PlanningSceneMsg) -> None:
        try:
            data = planning_scene_from_msg(msg)
            PlanningScene.from_msg(self.model, data)  # checked here, rebuilt by each user
        except (ConversionError, PlanningError) as exc:
            self.get_logger().warning(f"ignoring planning scene: {exc}")
            return
        with self._lock:
            self._scene_msg = data
            self._scene_version += 1

    # ------------------------------------------------------------------ services
    def _srv_switch(self, request: ServoCommandType.Request, response: ServoCommandType.Response):
        kind = int(request.command_type)
        if kind not in CommandType.NAMES:
            self.get_logger().warning(f"Unknown command type {kind} requested (JOINT_JOG=0, TWIST=1, POSE=2)")
            response.success = False
            return response
        with self._lock:
            self._command_type = kind
            self._legacy = False
        self.get_logger().info(f"command type is now {CommandType.NAMES[kind]}")
        response.success = True
        return response

    def _srv_pause(self, request: SetBool.Request, response: SetBool.Response):
        with self._lock:
            if self._paused and not request.data:
                self._resumed_at = time.time()
            self._paused = bool(request.data)
            self._latest.clear()
        response.success = True
        response.message = "servoing paused" if request.data else "servoing resumed"
        self.get_logger().info(response.message)
        return response

    def _srv_start(self, request: Trigger.Request, response: Trigger.Response):
        with self._lock:
            if self._paused:
                self._resumed_at = time.time()
            self._paused = False
            self._legacy = True
        response.success = True
        response.message = "servoing started (legacy start_servo: twists and joint jogs accepted)"
        self.get_logger().info(response.message)
        return response

    def _srv_stop(self, request: Trigger.Request, response: Trigger.Response):
        with self._lock:
            self._paused = True
            self._latest.clear()
        response.success = True
        response.message = "servoing stopped (legacy stop_servo)"
        self.get_logger().info(response.message)
        return response

    # ------------------------------------------------------------------ the loop
    def _collides(self, full: np.ndarray) -> bool:
        with self._lock:
            data, version = self._scene_msg, self._scene_version
        if data is None:
            return False
        if version != self._loop_scene_version:
            self._loop_scene = PlanningScene.from_msg(self.model, data)
            self._loop_scene_version = version
        self._loop_state.set_positions(full)
        return bool(self._loop_scene.is_state_colliding(self._loop_state))

    def _schedule_fifo(self, priority: int) -> bool:
        """The calling thread (and the threads it starts afterwards) under SCHED_FIFO at
        ``priority``; False (and a warning, as MoveIt's) without the right to it (no
        CAP_SYS_NICE / rtprio limit) or off Linux: the thread stays at normal priority."""
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        except (AttributeError, OSError) as exc:  # AttributeError: not Linux
            self.get_logger().warning(f"Could not enable FIFO RT scheduling policy ({exc}). Continuing with the "
                                      "default.")
            return False
        return True

    def _loop(self) -> None:
        if self._realtime:
            self._schedule_fifo(self._thread_priority)
        next_time = time.monotonic()
        while self._running:
            next_time += self._period
            delay = next_time - time.monotonic()
            if delay > 0 and self._wake.wait(delay):
                next_time = time.monotonic()  # a first command woke the idle loop: its ticks start here
            elif delay < -self._period:  # fell behind (suspended): do not try to catch up
                next_time = time.monotonic()
            self._wake.clear()
            try:
                self._iterate()
            except Exception as exc:  # one bad iteration must not stop the loop
                if self._throttle("loop error"):
                    self.get_logger().error(f"servo loop iteration failed: {type(exc).__name__}: {exc}")

    def _iterate(self) -> None:
        if not self.context.ok():  # shutting down
            self._running = False
            return
        now = time.time()  # the clock of command stamps
        with self._lock:
            measured = None if self._measured is None else self._measured.copy()
            paused = self._paused
            kind = self._command_type
            entry = self._latest.get(kind) if kind is not None else None
            invalid, self._invalid = self._invalid, None
            collision_scale, collision_status = self._collision
            params = self.servo.params
        self.loop_iterations += 1
        if measured is None:
            return  # waits for the first robot state
        if paused:
            self._synced = False
            return
        command = None
        if entry is not None and now - entry[1] <= params.incoming_command_timeout:
            command = entry[0]
        if command is not None and not self._synced:
            with self._lock:
                self.servo.reset(measured)
            self._synced = True
            self._rest_periods = 0
            self.get_logger().info(f"servoing the arm from where it is ({CommandType.NAMES[kind]} commands, "
                                   f"{now - entry[1]:.3f} s old)")
        if not self._synced:
            self._publish_status(StatusCode.INVALID if invalid else StatusCode.NO_WARNING, invalid)
            return
        with self._lock:
            step = self.servo.step(command, collision_scale, collision_status,
                                   self._collides if params.check_collisions else None)
        if step.moving or command is not None:
            self._rest_periods = 0
        else:
            self._rest_periods += 1
        if self._rest_periods <= REST_PERIODS:
            self._publish_command(step, now, measured)  # then quiet: the controller is free for others
            if self._rest_periods == REST_PERIODS:
                self.get_logger().info("the arm is at rest: servo_node stops commanding it")
        if step.status in (StatusCode.HALT_FOR_COLLISION, StatusCode.HALT_FOR_SINGULARITY, StatusCode.JOINT_BOUND) \
                and self._throttle(f"halt {step.status}"):
            why = STATUS_MESSAGES[step.status]
            if step.status == StatusCode.HALT_FOR_COLLISION:
                if collision_scale == 0.0:
                    why += f" ({self._nearest})"
                else:
                    contacts = self._loop_scene.check_collision(self._loop_state, max_contacts=1).contacts
                    why += f" (the next step would collide: {contacts[0] if contacts else 'contact'})"
            self.get_logger().warning(why)
        if self._rest_periods >= REST_PERIODS + (self._latency + RESUME_WINDOW) / self._period:
            self._synced = False  # the arm has arrived: the next command starts from the robot's state
        self._publish_status(StatusCode.INVALID if invalid else step.status, invalid)

    def _publish_status(self, code: int, reason: str | None) -> None:
        message = STATUS_MESSAGES[code] if reason is None else f"{STATUS_MESSAGES[code]}: {reason}"
        self._status_pub.publish(ServoStatus(code=code, message=message))

    def _publish_command(self, step: Any, tick: float, measured: np.ndarray) -> None:
        """The step's command, stamped with the iteration's start (``tick``, system time), its
        point max_expected_latency ahead -- or later, when the arm (as last measured) is farther
        from it than the velocity limits cover in that time (after the loop was held up)."""
        values = self._flags
        if self._output_is_trajectory:
            msg = JointTrajectory()
            msg.header.stamp.sec = int(tick)
            msg.header.stamp.nanosec = int((tick - int(tick)) * 1e9)
            msg.header.frame_id = ""
            msg.joint_names = self._joint_names
            point = JointTrajectoryPoint()
            if values[P + "publish_joint_positions"]:
                point.positions = step.positions.tolist()
            if values[P + "publish_joint_velocities"]:
                point.velocities = step.velocities.tolist()
            if values[P + "publish_joint_accelerations"]:
                point.accelerations = step.accelerations.tolist()
            gap = np.abs(step.positions - measured[self.servo.indices]) / self.servo.vmax
            point.time_from_start = seconds_to_duration(max(self._latency, float(np.max(gap)) * 1.05))
            msg.points = [point]
        else:
            msg = Float64MultiArray()
            data = step.positions if values[P + "publish_joint_positions"] else step.velocities
            msg.data = data.tolist()
        self._out_pub.publish(msg)

    # ------------------------------------------------------------------ collision monitor
    def _collision_loop(self) -> None:
        scene: PlanningScene | None = None
        version = -1
        state = RobotState(self.model)
        while self._running:
            time.sleep(1.0 / self.servo.params.collision_check_rate)
            with self._lock:
                params = self.servo.params
                data, current = self._scene_msg, self._scene_version
                full = self.servo.full_positions if self._synced else (
                    None if self._measured is None else self._measured.copy())
            if not params.check_collisions or full is None:
                continue
            try:
                if data is not None and current != version:
                    scene, version = PlanningScene.from_msg(self.model, data), current
                if scene is None:
                    scene = PlanningScene(self.model)
                state.set_positions(full)
                self_report = scene.distance(state, include_world=False)
                scene_report = scene.distance(state, include_self=False)
                result = collision_velocity_scale(self_report.min_distance, scene_report.min_distance,
                                                  params.self_collision_proximity_threshold,
                                                  params.scene_collision_proximity_threshold)
                nearest = min(self_report, scene_report, key=lambda r: r.min_distance)
            except Exception as exc:
                if self._throttle("collision error"):
                    self.get_logger().error(f"collision monitor failed: {type(exc).__name__}: {exc}")
                continue
            with self._lock:
                self._collision = result
                self._nearest = str(nearest)

    def close(self) -> None:
        """Stop the loop and the collision monitor (run_node calls this before shutdown)."""
        self._running = False
        for thread in (self._loop_thread, self._collision_thread):
            if thread.is_alive() and thread is not threading.current_thread():
                thread.join(timeout=2.0)

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()
