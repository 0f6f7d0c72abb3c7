"""Scan-N-Plan's vision node: where is the part? (the seed's LocalizePart service)

The full story: docs/nodes.md, section mycobot_planning.ros.demos.part_localizer.
"""
from __future__ import annotations

import json
import threading
import time
from typing import Any

from geometry_msgs.msg import PoseStamped
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from std_srvs.srv import Trigger

from interfaces_py.json_rpc import BAD_REQUEST, JsonRpcServer, RpcError
from interfaces_py.msgs import MessageError, Pose
from mycobot_planning.ros.node_runtime import Parameters, ParameterSpec
from mycobot_planning.demos.seed_scenarios import DEFAULT_CAMERA_POSE, localize, pose_from_list, pose_list_check

NODE_NAME = "part_localizer"
NO_MARKER = -1  # RPC error codes of localize_part
STALE_MARKER = -2
UNKNOWN_FRAME = -3


class PartLocalizer(Node):
    """See docs/nodes.md (mycobot_planning.ros.demos.part_localizer)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.params = Parameters(self, [
            ParameterSpec("marker_topic", "/ar_pose_marker", "topic of the marker pose (geometry_msgs/PoseStamped)",
                          non_empty=True, read_only=True),
            ParameterSpec("base_frame", "world", "frame the Trigger service reports the part in", non_empty=True),
            ParameterSpec("camera_frame", "camera_frame", "frame of the camera the marker poses are expressed in",
                          non_empty=True),
            ParameterSpec("camera_pose", list(DEFAULT_CAMERA_POSE),
                          "mounting pose of the camera in the base frame [x, y, z, qx, qy, qz, qw] (m)",
                          array_size=7, validator=pose_list_check("camera_pose")),
            ParameterSpec("max_marker_age", 2.0, "refuse marker poses older than this (s); 0 accepts any age",
                          range=(0.0, 3600.0)),
        ])
        self._lock = threading.Lock()
        self._marker: tuple[Pose, str, float] | None = None  # pose, frame, monotonic receipt time
        self._warned_frame: str | None = None
        group = ReentrantCallbackGroup()
        topic = self.params.get("marker_topic")
        self.create_subscription(PoseStamped, topic, self._on_marker, 10, callback_group=group)
        self.create_service(Trigger, "~/localize_part", self._srv_localize, callback_group=group)
        self._rpc = JsonRpcServer(self)
        self._rpc.register("localize_part", self._rpc_localize)
        self.get_logger().info(f"part_localizer ready: marker poses from {topic}, parts reported in "
                               f"'{self.params.get('base_frame')}'")

    def _on_marker(self, msg: PoseStamped) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        try:
            pose = Pose(position=[p.x, p.y, p.z], orientation=[q.x, q.y, q.z, q.w])
        except MessageError as exc:
            self.get_logger().warning(f"ignoring a malformed marker pose: {exc}", throttle_duration_sec=5.0)
            return
        with self._lock:
            self._marker = (pose, msg.header.frame_id, time.monotonic())

    def localize(self, base_frame: str | None = None) -> dict[str, Any]:
        """The part's pose in ``base_frame`` (default: the parameter), RpcError saying why not."""
        frame = base_frame or self.params.get("base_frame")
        camera_frame = self.params.get("camera_frame")
        with self._lock:
            marker = self._marker
        topic = self.params.get("marker_topic")
        if marker is None:
            raise RpcError(NO_MARKER, f"no marker seen yet on {topic}: is the marker publisher running?")
        pose, marker_frame, received = marker
        age = time.monotonic() - received
        max_age = float(self.params.get("max_marker_age"))
        if max_age > 0 and age > max_age:
            raise RpcError(STALE_MARKER, f"the last marker on {topic} is {age:.1f} s old (max_marker_age {max_age:g} s)")
        if marker_frame and marker_frame != camera_frame:
            raise RpcError(UNKNOWN_FRAME, f"the marker pose is in frame '{marker_frame}', but only the camera frame "
                                          f"'{camera_frame}' is known")
        if frame == camera_frame:
            part = pose
        elif frame == self.params.get("base_frame"):
            part = localize(pose, pose_from_list(self.params.get("camera_pose"), "camera_pose"))
        else:
            raise RpcError(UNKNOWN_FRAME, f"unknown base frame '{frame}'; known: "
                                          f"'{self.params.get('base_frame')}', '{camera_frame}'")
        return {"pose": part.to_dict(), "frame_id": frame, "marker_age": age}

    def _srv_localize(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            result = self.localize()
        except RpcError as exc:
            self.get_logger().warning(f"localize_part: {exc.message}")
            response.success, response.message = False, exc.message
            return response
        self.get_logger().info(f"localized the part at {[round(v, 4) for v in result['pose']['position']]} "
                               f"in '{result['frame_id']}'")
        response.success, response.message = True, json.dumps(result)
        return response

    def _rpc_localize(self, params: dict[str, Any]) -> dict[str, Any]:
        unknown = sorted(set(params) - {"base_frame"})
        if unknown:
            raise RpcError(BAD_REQUEST, f"localize_part: unknown parameters {unknown}; known: ['base_frame']")
        frame = params.get("base_frame")
        if frame is not None and (not isinstance(frame, str) or not frame):
            raise RpcError(BAD_REQUEST, "localize_part: base_frame must be a frame name")
        return self.localize(frame)
