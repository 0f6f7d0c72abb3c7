"""robot_state_publisher: what RViz needs to show the robot, as ROS's robot_state_publisher does.

* ``/robot_description`` (std_msgs/String, transient local): the URDF, once.
* ``/tf_static`` (tf2_msgs/TFMessage, transient local): every fixed joint's transform, once.
* ``/tf`` (tf2_msgs/TFMessage): every moving joint's transform (mimic joints included) at each
  ``/joint_states`` message, at most ``publish_frequency`` times per second.

Parameters: ``robot_description`` (URDF text; empty: the package's myCobot 280),
``publish_frequency`` (Hz). The transforms come from core/robot_state/tf_tree.py.
"""
from __future__ import annotations

import time

from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from mycobot_planning.core.errors import StateError
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.robot_state.tf_tree import Transform, joint_transforms
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.paths import config_file

LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class RobotStatePublisher(Node):
    """See the module docstring."""

    def __init__(self) -> None:
        super().__init__("robot_state_publisher")
        self._params = Parameters(self, [
            ParameterSpec("robot_description", "", "URDF of the robot (XML text); empty: the package's myCobot 280",
                          read_only=True),
            ParameterSpec("publish_frequency", 20.0, "most /tf messages per second (Hz)", range=(0.1, 1000.0),
                          dynamic_typing=True),
        ])
        urdf = self._params.get("robot_description")
        self.model = RobotModel.from_strings(urdf, '<robot name=""/>') if urdf else RobotModel.mycobot()
        text = urdf or config_file("mycobot_280.urdf").read_text()
        self._state = RobotState(self.model)
        self._last = 0.0
        self._warned = 0.0
        description = self.create_publisher(String, "/robot_description", LATCHED_QOS)
        description.publish(String(data=text))
        self._static = self.create_publisher(TFMessage, "/tf_static", LATCHED_QOS)
        self._static.publish(self._message(joint_transforms(self.model, self._state, fixed=True)))
        self._tf = self.create_publisher(TFMessage, "/tf", 100)
        self.create_subscription(JointState, "/joint_states", self._on_joint_states, 10)
        self.get_logger().info(f"robot_state_publisher ready: robot '{self.model.name}', "
                               f"{len(self.model.joint_names)} joints")

    def _message(self, transforms: list[Transform]) -> TFMessage:
        stamp = self.get_clock().now().to_msg()
        msg = TFMessage()
        for parent, child, xyz, quat in transforms:
            t = TransformStamped()
            t.header.stamp = stamp
            t.header.frame_id, t.child_frame_id = parent, child
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
            (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
             t.transform.rotation.w) = quat
            msg.transforms.append(t)
        return msg

    def _on_joint_states(self, msg: JointState) -> None:
        now = time.monotonic()
        if now - self._last < 1.0 / float(self._params.get("publish_frequency")):
            return
        active = set(self.model.variable_names)
        values = {n: p for n, p in zip(msg.name, msg.position) if n in active}
        try:
            self._state.set_joint_positions(values)
        except StateError as exc:
            if now - self._warned > 5.0:
                self._warned = now
                self.get_logger().warning(f"ignoring /joint_states message: {exc}")
            return
        self._last = now
        self._tf.publish(self._message(joint_transforms(self.model, self._state, fixed=False)))
