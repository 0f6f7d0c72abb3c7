"""Scan-N-Plan's fake AR marker publisher: the pose of a marker on the part, as a camera reports it.

The seed's ``fake_ar_publisher`` stands in for a camera and an AR tag detector: it keeps
publishing the pose of one marker in the camera's frame, plus a visualization marker. There is
no ar_track_alvar message here, so the pose travels as a standard geometry_msgs/PoseStamped.

Topics:

* ``/ar_pose_marker`` (geometry_msgs/PoseStamped): the marker pose in ``camera_frame``, at
  ``rate`` Hz.
* ``/ar_pose_visual`` (visualization_msgs/Marker): a thin cube at that pose, for RViz.

Parameters: ``marker_pose`` [x, y, z, qx, qy, qz, qw] in the camera frame (the default puts the
part 0.10 m above the table in front of the myCobot, see seed_scenarios; changeable at run
time with ``ros2 param set``: the part "moves"), ``camera_frame``, ``rate``, ``topic``.

Runs until Ctrl-C: ``ros2 run mycobot_planning fake_marker_publisher``.
"""
from __future__ import annotations

from typing import Any

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from visualization_msgs.msg import Marker

from interfaces_py.msgs import Pose
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.demos.seed_scenarios import DEFAULT_MARKER_POSE, pose_from_list, pose_list_check

NODE_NAME = "fake_marker_publisher"
MARKER_SIZE = (0.04, 0.04, 0.002)  # m: a printed tag's square


class FakeMarkerPublisher(Node):
    """See the module docstring."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.params = Parameters(self, [
            ParameterSpec("marker_pose", list(DEFAULT_MARKER_POSE),
                          "pose of the marker in the camera frame [x, y, z, qx, qy, qz, qw] (m)", array_size=7,
                          validator=pose_list_check("marker_pose")),
            ParameterSpec("camera_frame", "camera_frame", "frame the marker pose is expressed in", non_empty=True,
                          read_only=True),
            ParameterSpec("rate", 10.0, "publications per second", range=(0.1, 1000.0), read_only=True),
            ParameterSpec("topic", "/ar_pose_marker", "topic of the marker pose", non_empty=True, read_only=True),
        ])
        self._pose = pose_from_list(self.params.get("marker_pose"), "marker_pose")
        self._frame = self.params.get("camera_frame")
        self._pose_pub = self.create_publisher(PoseStamped, self.params.get("topic"), 10)
        self._visual_pub = self.create_publisher(Marker, "/ar_pose_visual", 10)
        self.params.on_change(self._on_change)
        self.create_timer(1.0 / float(self.params.get("rate")), self._publish)
        self.get_logger().info(
            f"fake_marker_publisher ready: publishing {self.params.get('topic')} in '{self._frame}' at "
            f"{self.params.get('rate'):g} Hz, marker at {[round(v, 4) for v in self._pose.position]}")

    def _on_change(self, changed: dict[str, Any]) -> None:
        if "marker_pose" in changed:
            self._pose = pose_from_list(changed["marker_pose"], "marker_pose")
            self.get_logger().info(f"marker moved to {[round(v, 4) for v in self._pose.position]}")

    def _publish(self) -> None:
        pose: Pose = self._pose
        msg = PoseStamped()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self._frame
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in pose.position)
        (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
         msg.pose.orientation.w) = (float(v) for v in pose.orientation)
        self._pose_pub.publish(msg)
        visual = Marker()
        visual.header = msg.header
        visual.ns = "ar_marker"
        visual.id = 0
        visual.type = Marker.CUBE
        visual.action = Marker.ADD
        visual.pose = msg.pose
        visual.scale.x, visual.scale.y, visual.scale.z = MARKER_SIZE
        visual.color.r, visual.color.g, visual.color.b, visual.color.a = 0.1, 0.6, 0.1, 1.0
        self._visual_pub.publish(visual)
