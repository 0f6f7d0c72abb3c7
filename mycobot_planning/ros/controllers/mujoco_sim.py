"""The MuJoCo twin as a ROS node: the controller manager over the simulation's plant
(simulation/mujoco_plant.py), so it offers exactly what mock_controllers offers
(/arm_controller/follow_joint_trajectory, /grip_action_controller/gripper_cmd, the joint_trajectory
topics, controller_state, state, stop, /joint_states from the simulated joints), plus what only a
simulation knows:

* ``/mujoco_sim/object_poses`` (tf2_msgs/TFMessage): every scene object's true pose, one
  transform per object (child_frame_id = the object's id, in the scene's frame), at
  ``object_pose_rate``;
* with ``camera_rate`` > 0, the scene's depth camera rendered headless as sensor_msgs/PointCloud2
  on ``cloud_topic`` (the seeds' /camera_head/depth/color/points), in the scene's frame;
* ``/mujoco_sim/status`` (std_msgs/String, JSON): simulated time, real-time factor, whether it
  falls behind real time (and by how much), and the gripper's holds (which object it held, how
  much it slipped in the hand, how the hold ended), at ``status_rate`` and at once when falling
  behind starts or ends (the log says so too);
* world services (ros/controllers/sim_services.py): reset the world, pause and step, spawn and
  remove objects, on the JSON face (``/mujoco_sim/requests``) and, for the data-free ones, as
  std_srvs services (``/mujoco_sim/reset_world``, ``/mujoco_sim/pause``).

    ros2 run mycobot_planning mujoco_sim [--ros-args -p speed_factor:=0.5 -p scene_file:=my_scene.yaml]

A bad model or scene (an unreadable mesh, a free body without mass, a bad scene file) is refused
before anything starts, naming the part. The physics and the model: docs/simulation.md.
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import replace
from typing import Any

from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import PointCloud2
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.trajectory_execution.controllers_config import ControllerManagerConfig
from mycobot_planning.core.transforms import pose_to_xyz_quat
from mycobot_planning.paths import config_file
from mycobot_planning.ros.controllers.controller_manager import ControllerManager
from mycobot_planning.ros.controllers.sim_services import SimServices
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.perception.pointcloud_layout import pack_xyzrgb
from mycobot_planning.ros.perception.camera_simulator import point_cloud2
from mycobot_planning.simulation import DepthFrame, MujocoSimulator, SimulationError, load_settings
from mycobot_planning.simulation.mujoco_plant import MujocoPlant, SimTracking

NODE_NAME = "mujoco_sim"
OBJECT_POSES_TOPIC = f"/{NODE_NAME}/object_poses"
#: the seeds' camera_head topic, where perception_server listens by default
CLOUD_TOPIC = "/camera_head/depth/color/points"
CLOUD_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
STATUS_TOPIC = f"/{NODE_NAME}/status"
STATUS_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
POSES_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
#: s between two checks for a change of "behind real time" (published at once when it changes)
BEHIND_CHECK_PERIOD = 0.1


def _seconds(name: str, low: float, high: float):
    def check(value: Any) -> str | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or not low <= value <= high:
            return f"{name} must be a number within [{low:g}, {high:g}], got {value!r}"
        return None

    return check


def load_mujoco_plant(node: ControllerManager, model: RobotModel, config: ControllerManagerConfig) -> MujocoPlant:
    """The simulation's plant with its parameters on ``node`` (scene, settings, speed factor,
    tracking tolerances, the hand the grasp watch uses). Raises ValueError (the node exits with
    the message) when the model or scene cannot be built."""
    plant: MujocoPlant | None = None

    def speed_check(value: Any) -> str | None:
        reason = _seconds("speed_factor", 0.0, 100.0)(value)
        if reason is None and plant is not None:
            busy = [f"{name} is executing goal {f.goal_id}" for name, (f, _) in plant.followers.items() if f.active]
            if busy:
                reason = (f"cannot change speed_factor while {busy[0]}: the controllers' clock and the physics "
                          "would part mid-trajectory; stop it first")
        return reason

    p = Parameters(node, [
        ParameterSpec("scene_file", "", "the simulated world (floor, objects with mass and friction, camera): a "
                      "scene YAML (docs/simulation.md); empty: config/mujoco_scene.yaml, the seeds' table and "
                      "cylinder", read_only=True),
        ParameterSpec("settings_file", "", "servo gains, time step and contact settings: a parameter file of "
                      "the layout of config/mujoco_sim.yaml; empty: that file", read_only=True),
        ParameterSpec("speed_factor", 0.0, "simulated seconds per wall second (0.5: half speed); 0: the "
                      "settings file's speed_factor (1.0). The controllers run on the wall clock, so below 1 "
                      "the arm lags their trajectories more. Settable while no controller follows a goal",
                      range=(0.0, 100.0), validator=speed_check, dynamic_typing=True),
        ParameterSpec("object_pose_rate", 20.0, f"Hz of {OBJECT_POSES_TOPIC} (the objects' true poses)",
                      range=(1.0, 200.0), read_only=True, dynamic_typing=True),
        ParameterSpec("status_rate", 1.0, f"Hz of {STATUS_TOPIC} (also published at once when the simulation "
                      "starts or stops falling behind real time)", range=(0.1, 50.0), read_only=True,
                      dynamic_typing=True),
        ParameterSpec("camera_rate", 0.0, "Hz of simulated time of the scene's depth camera, rendered headless "
                      "and published as sensor_msgs/PointCloud2 on cloud_topic; 0: no camera (no CPU spent on it)",
                      range=(0.0, 30.0), read_only=True, dynamic_typing=True),
        ParameterSpec("cloud_topic", CLOUD_TOPIC, "topic of the rendered clouds (camera_rate > 0)", non_empty=True,
                      read_only=True),
        ParameterSpec("hand_link", "", "link whose frame the grasp watch measures a held object's slip in; "
                      "empty: the parent link of the SRDF's first end effector", read_only=True),
        ParameterSpec("stop_on_lost_grasp", True, "a held object leaving the hand (2 cm from where it was held, "
                      "the gripper not opened) aborts the arm's goal and the arm holds where it is, as a grasp check "
                      "would: a grasp that did not hold stops the pick and place instead of sweeping the arm "
                      "through the object it left behind", read_only=True),
        ParameterSpec("path_tolerance", 0.2, "rad: a goal is aborted when a simulated joint is farther than "
                      "this from the trajectory's desired position; a goal's own path_tolerance applies too",
                      range=(0.001, 10.0), read_only=True, dynamic_typing=True),
        ParameterSpec("goal_time", 1.0, "s after a trajectory's end for the simulated arm to come within the "
                      "goal tolerance, else the goal is aborted", range=(0.0, 60.0), read_only=True,
                      dynamic_typing=True),
        ParameterSpec("gripper_goal_time", 3.0, "s after a gripper move's end for the simulated gripper to "
                      "arrive or stall on an object", range=(0.0, 60.0), read_only=True, dynamic_typing=True),
    ])
    hand = p.get("hand_link")
    if not hand:
        eefs = list(model.end_effectors.values())
        hand = eefs[0].parent_link if eefs else ""
    speed = float(p.get("speed_factor"))
    try:
        settings = load_settings(p.get("settings_file") or config_file("mujoco_sim.yaml"))
        file_speed = settings.speed_factor
        if speed > 0:
            settings = replace(settings, speed_factor=speed)
        camera_rate = float(p.get("camera_rate"))
        settings = replace(settings, camera_rate=camera_rate)
        sim = MujocoSimulator(model, p.get("scene_file") or config_file("mujoco_scene.yaml"), settings,
                              camera=camera_rate > 0)
        if camera_rate > 0 and sim.scene.camera is None:
            raise SimulationError(f"camera_rate is {camera_rate:g} Hz but the scene has no camera (give camera or "
                                  "camera_file in the scene file)")
    except (SimulationError, OSError) as exc:
        raise ValueError(f"mujoco_sim: {exc}") from None
    tracking = SimTracking(float(p.get("path_tolerance")), float(p.get("goal_time")),
                           float(p.get("gripper_goal_time")))
    plant = MujocoPlant(model.variable_names, model.default_positions(), sim, config.controllers, tracking,
                        own_simulator=True, hand_link=hand, stop_on_lost_grasp=bool(p.get("stop_on_lost_grasp")))

    def on_change(changed: dict[str, Any]) -> None:
        if "speed_factor" in changed:
            value = float(changed["speed_factor"])
            sim.set_speed_factor(value if value > 0 else file_speed)
            node.get_logger().info(f"the simulation now runs at {sim.speed_factor:g} x real time")

    p.on_change(on_change)
    return plant


class _RosLogHandler(logging.Handler):
    """The simulation layer's log lines (falling behind real time, a stopped physics thread) in
    the node's log."""

    def __init__(self, node: "MujocoSimNode") -> None:
        super().__init__(logging.INFO)
        self.node = node

    def emit(self, record: logging.LogRecord) -> None:
        level = "error" if record.levelno >= logging.ERROR else "warning" if record.levelno >= logging.WARNING \
            else "info"
        self.node._plant_log(level, record.getMessage())


class MujocoSimNode(ControllerManager):
    """The node ``mujoco_sim`` (see the module docstring)."""

    def __init__(self) -> None:
        self._log_handler: _RosLogHandler | None = None
        super().__init__(NODE_NAME, load_mujoco_plant)
        plant: MujocoPlant = self.plant
        self.sim = plant.sim
        self._log_handler = _RosLogHandler(self)
        sim_logger = logging.getLogger("mycobot_planning.simulation")
        sim_logger.addHandler(self._log_handler)
        sim_logger.setLevel(logging.INFO)
        sim_logger.propagate = False
        self._frame = self.sim.scene.frame_id
        self._poses_pub = self.create_publisher(TFMessage, OBJECT_POSES_TOPIC, POSES_QOS)
        self._status_pub = self.create_publisher(String, STATUS_TOPIC, STATUS_QOS)
        group = MutuallyExclusiveCallbackGroup()
        self._behind = False
        self._status_period = 1.0 / float(self.get_parameter("status_rate").value)
        self._since_status = math.inf
        self.create_timer(1.0 / float(self.get_parameter("object_pose_rate").value), self._publish_poses,
                          callback_group=group)
        self.create_timer(min(BEHIND_CHECK_PERIOD, self._status_period), self._status_tick, callback_group=group)
        self._cloud_pub = None
        self._frames = 0
        if float(self.get_parameter("camera_rate").value) > 0:
            self._cloud_pub = self.create_publisher(PointCloud2, self.get_parameter("cloud_topic").value, CLOUD_QOS)
            self.sim.on_frame(self._publish_cloud)
        self.world_services = SimServices(self)
        self.get_logger().info(
            f"simulating {', '.join(self.sim.scene.object_ids) or 'no objects'} in '{self._frame}' at speed factor "
            f"{self.sim.speed_factor:g}; object poses on {OBJECT_POSES_TOPIC}, status on {STATUS_TOPIC}")

    def _publish_poses(self) -> None:
        stamp = self.get_clock().now().to_msg()
        msg = TFMessage()
        for name, pose in self.sim.object_poses().items():
            xyz, quat = pose_to_xyz_quat(pose)
            t = TransformStamped()
            t.header.stamp = stamp
            t.header.frame_id = self._frame
            t.child_frame_id = name
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (float(v) for v in xyz)
            (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
             t.transform.rotation.w) = (float(v) for v in quat)
            msg.transforms.append(t)
        self._poses_pub.publish(msg)

    def _publish_cloud(self, frame: DepthFrame) -> None:
        """A rendered depth frame as an organised XYZRGB cloud (called in the camera's thread)."""
        if self._closing:
            return
        msg = point_cloud2(pack_xyzrgb(frame.points), frame.frame_id, self.get_clock().now().to_msg())
        self._cloud_pub.publish(msg)
        self._frames += 1
        if self._frames == 1:
            self.get_logger().info(f"published the first rendered cloud ({msg.width}x{msg.height}, frame "
                                   f"'{msg.header.frame_id}') on {self.get_parameter('cloud_topic').value}")

    def status_dict(self) -> dict[str, Any]:
        s = self.sim.status()
        with self._lock:  # the grasp watch is sampled in the control loop, under this lock
            holds = [h.as_dict() for h in self.plant.grasp.holds]
        return {"time": round(s.time, 4), "steps": s.steps, "running": s.running, "paused": s.paused,
                "speed_factor": s.speed_factor, "real_time_factor": round(s.real_time_factor, 3),
                "behind_real_time": s.behind_real_time, "lag": round(s.lag, 4), "message": s.message,
                "camera_frames": s.camera_frames, "camera_frame_time": round(s.camera_frame_time, 4),
                "holds": holds}

    def _status_tick(self) -> None:
        self._since_status += min(BEHIND_CHECK_PERIOD, self._status_period)
        behind = self.sim.status().behind_real_time
        if behind == self._behind and self._since_status < self._status_period - 1e-9:
            return
        self._behind = behind
        self._since_status = 0.0
        self._status_pub.publish(String(data=json.dumps(self.status_dict())))

    def close(self) -> None:
        super().close()
        if self._log_handler is not None:
            logging.getLogger("mycobot_planning.simulation").removeHandler(self._log_handler)


def mujoco_sim() -> MujocoSimNode:
    """The node ``mujoco_sim`` of ``ros2 run mycobot_planning mujoco_sim``."""
    return MujocoSimNode()
