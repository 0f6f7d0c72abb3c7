"""robot_state_publisher: what RViz needs to show the robot, as ROS's robot_state_publisher does.

* ``/robot_description`` (std_msgs/String, transient local): the URDF, once.
* ``/tf_static`` (tf2_msgs/TFMessage, transient local): every fixed joint's transform, once.
* ``/tf`` (tf2_msgs/TFMessage): every moving joint's transform (mimic joints included) when
  ``/joint_states`` changes, at most ``publish_frequency`` times per second, and once a second
  while it stays the same (so that a listener that joins late gets the moving frames too).

/joint_states is read at ``publish_frequency`` by a thread of the node (a TopicReader: the newest
message only), not by the executor at each of the controllers' 100 messages a second: idle, the
node costs about 1 % of a core instead of 15-30 %.

Parameters: ``robot_description`` (URDF text; empty: the package's myCobot 280),
``publish_frequency`` (Hz). The transforms come from core/robot_state/tf_tree.py.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np

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
from mycobot_planning.ros.topic_reader import TopicReader
from mycobot_planning.paths import config_file

#: s between two /tf messages while the joints stand still
KEEP_ALIVE_PERIOD = 1.0

LATCHED_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class RobotStatePublisher(Node):
    """See the module docstring."""

    def __init__(self, **node_options: Any) -> None:
        """``node_options``: rclpy Node keyword arguments (e.g. ``context``)."""
        super().__init__("robot_state_publisher", **node_options)
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
        self._published: np.ndarray | None = None  # positions of the last /tf message
        description = self.create_publisher(String, "/robot_description", LATCHED_QOS)
        description.publish(String(data=text))
        self._static = self.create_publisher(TFMessage, "/tf_static", LATCHED_QOS)
        self._static.publish(self._message(joint_transforms(self.model, self._state, fixed=True)))
        self._tf = self.create_publisher(TFMessage, "/tf", 100)
        self._joint_states = TopicReader(self, JointState, "/joint_states", 1)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="tf publisher", daemon=True)
        self._thread.start()
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

    def _loop(self) -> None:
        """Read the newest /joint_states at publish_frequency; publish /tf when it changed (or
        KEEP_ALIVE_PERIOD after the last)."""
        while not self._stop.wait(1.0 / float(self._params.get("publish_frequency"))):
            msg = self._joint_states.take_latest()
            if msg is None:
                if self._published is not None and time.monotonic() - self._last >= KEEP_ALIVE_PERIOD:
                    self._publish()
                continue
            try:
                self._on_joint_states(msg)
            except Exception as exc:  # a context shut down under us, or a bad message: say so, go on
                if self._stop.is_set() or not self.context.ok():
                    return
                self.get_logger().error(f"publishing /tf failed: {type(exc).__name__}: {exc}")

    def _on_joint_states(self, msg: JointState) -> None:
        now = time.monotonic()
        active = set(self.model.variable_names)
        values = {n: p for n, p in zip(msg.name, msg.position) if n in active}
        try:
            self._state.set_joint_positions(values)
        except StateError as exc:
            if now - self._warned > 5.0:
                self._warned = now
                self.get_logger().warning(f"ignoring /joint_states message: {exc}")
            return
        positions = self._state.positions
        if self._published is not None and np.array_equal(positions, self._published) \
                and now - self._last < KEEP_ALIVE_PERIOD:
            return
        self._publish()

    def _publish(self) -> None:
        self._last = time.monotonic()
        self._published = self._state.positions.copy()
        self._tf.publish(self._message(joint_transforms(self.model, self._state, fixed=False)))

    def close(self) -> None:
        """Stop the reading thread, then the subscription (before the node goes)."""
        self._stop.set()
        self._joint_states.wake()
        self._thread.join(2.0)
        self._joint_states.destroy()
