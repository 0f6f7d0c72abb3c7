"""Pose behaviors of MoveIt Pro's core set: create a PoseStamped, transform it (by an offset, or
into another frame), show it. The objective files of the ROSCon'24 workshop use them to pass
poses through the blackboard (CreateStampedPose -> TransformPose -> VisualizePose)."""
from __future__ import annotations

from typing import Any

import numpy as np

from interfaces_py.msgs import Pose

from ...core.transforms import make_pose, matrix_to_quat
from ..action_node import SyncActionNode
from ..basic_types import FAILURE, SUCCESS, NodeStatus
from ..ports import DOUBLE, POSE_STAMPED, STRING, VECTOR_DOUBLE, PoseStamped, input_port, output_port
from .context import BehaviorContext


def _pose_from(position: list[float], orientation: list[float], what: str) -> Pose:
    if len(position) != 3:
        raise ValueError(f"{what}: position_xyz needs 3 numbers x;y;z, got {len(position)}")
    if len(orientation) != 4:
        raise ValueError(f"{what}: orientation_xyzw needs 4 numbers x;y;z;w, got {len(orientation)}")
    return Pose(position=[float(v) for v in position], orientation=[float(v) for v in orientation])


def pose_matrix(pose: Pose) -> np.ndarray:
    return make_pose(pose.position, quat_xyzw=pose.orientation)


def matrix_pose(matrix: np.ndarray) -> Pose:
    return Pose(position=[float(v) for v in matrix[:3, 3]], orientation=[float(v) for v in matrix_to_quat(matrix[:3, :3])])


class _ContextAction(SyncActionNode):
    def __init__(self, name: str, config: Any, context: BehaviorContext):
        super().__init__(name, config)
        self.context = context

    def fail(self, why: str) -> NodeStatus:
        self.context.log("error", f"{self.config.path or self.name}: {why}")
        return FAILURE


class CreatePoseStamped(_ContextAction):
    DESCRIPTION = ("Creates a geometry_msgs/PoseStamped from a frame, a position and a quaternion and writes it to "
                   "the blackboard (e.g. a target pose to plan to).")
    OUTPUT = "pose_stamped"

    @classmethod
    def provided_ports(cls):
        return (input_port("reference_frame", STRING, "world", "the frame the pose is expressed in"),
                input_port("position_xyz", VECTOR_DOUBLE, [0.0, 0.0, 0.0], "x;y;z of the position (m)"),
                input_port("orientation_xyzw", VECTOR_DOUBLE, [0.0, 0.0, 0.0, 1.0],
                           "x;y;z;w of the orientation quaternion"),
                output_port(cls.OUTPUT, POSE_STAMPED, description="the pose created"))

    def tick(self) -> NodeStatus:
        try:
            pose = _pose_from(self.get_input("position_xyz"), self.get_input("orientation_xyzw"), self.name)
        except ValueError as exc:
            return self.fail(str(exc))
        self.set_output(self.OUTPUT, PoseStamped(self.get_input("reference_frame"), pose))
        return SUCCESS


class CreateStampedPose(CreatePoseStamped):
    DESCRIPTION = CreatePoseStamped.DESCRIPTION + " (The older name of CreatePoseStamped.)"
    OUTPUT = "stamped_pose"


class TransformPose(_ContextAction):
    DESCRIPTION = ("Transforms a stamped pose by a translation and a rotation expressed in the pose's own axes "
                   "(output = input * offset); the frame stays the input's. output_pose may be input_pose's entry.")

    @classmethod
    def provided_ports(cls):
        return (input_port("input_pose", POSE_STAMPED, description="the pose to transform"),
                input_port("translation_xyz", VECTOR_DOUBLE, [0.0, 0.0, 0.0], "x;y;z of the translation (m)"),
                input_port("quaternion_xyzw", VECTOR_DOUBLE, [0.0, 0.0, 0.0, 1.0], "x;y;z;w of the rotation"),
                input_port("position_xyz", VECTOR_DOUBLE, description="older name of translation_xyz",
                           required=False),
                input_port("orientation_xyzw", VECTOR_DOUBLE, description="older name of quaternion_xyzw",
                           required=False),
                output_port("output_pose", POSE_STAMPED, description="the transformed pose"))

    def tick(self) -> NodeStatus:
        stamped: PoseStamped = self.get_input("input_pose")
        translation = self.get_input("position_xyz", None) if self.has_input("position_xyz") else None
        rotation = self.get_input("orientation_xyzw", None) if self.has_input("orientation_xyzw") else None
        try:
            offset = _pose_from(translation or self.get_input("translation_xyz"),
                                rotation or self.get_input("quaternion_xyzw"), self.name)
        except ValueError as exc:
            return self.fail(str(exc))
        result = matrix_pose(pose_matrix(stamped.pose) @ pose_matrix(offset))
        self.set_output("output_pose", PoseStamped(stamped.frame_id, result))
        return SUCCESS


class TransformPoseFrame(_ContextAction):
    DESCRIPTION = "Expresses a stamped pose in another frame (the robot's TF tree)."

    @classmethod
    def provided_ports(cls):
        return (input_port("input_pose", POSE_STAMPED, description="the pose to express in target_frame_id"),
                input_port("target_frame_id", STRING, description="the frame to express it in"),
                output_port("output_pose", POSE_STAMPED, description="the same pose in target_frame_id"))

    def tick(self) -> NodeStatus:
        stamped: PoseStamped = self.get_input("input_pose")
        target = self.get_input("target_frame_id")
        try:
            transform = self.context.lookup_transform(target, stamped.frame_id)
        except LookupError as exc:
            return self.fail(str(exc))
        self.set_output("output_pose", PoseStamped(target, matrix_pose(transform @ pose_matrix(stamped.pose))))
        return SUCCESS


class VisualizePose(_ContextAction):
    DESCRIPTION = "Shows a stamped pose as an axes marker (visualization_msgs/MarkerArray on /visual_markers)."

    @classmethod
    def provided_ports(cls):
        return (input_port("pose", POSE_STAMPED, description="the pose to show"),
                input_port("marker_name", STRING, "pose", "the marker's namespace (a new pose replaces the old one)"),
                input_port("marker_size", DOUBLE, 0.1, "length of the axes (m)"),
                input_port("marker_lifetime", DOUBLE, 0.0, "how long the marker stays (s); 0: until replaced"),
                input_port("marker_text", STRING, "", "a label shown by the pose"))

    def tick(self) -> NodeStatus:
        self.context.visualize_pose(self.get_input("marker_name"), self.get_input("pose"),
                                    self.get_input("marker_size"), self.get_input("marker_lifetime"),
                                    self.get_input("marker_text"))
        return SUCCESS


POSE_BEHAVIORS = (CreatePoseStamped, CreateStampedPose, TransformPose, TransformPoseFrame, VisualizePose)
