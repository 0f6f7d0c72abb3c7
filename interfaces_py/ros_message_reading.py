"""Reading MoveIt's ROS messages into our JSON forms, by their fields only: nothing here imports
the generated message classes, so ROS-free layers (the task constructor) can accept a
moveit_msgs object a user built, and moveit_conversions (the ROS side) reads them the same way."""
from __future__ import annotations

from typing import Any

#: moveit_msgs/MoveItErrorCodes FAILURE.
FAILURE = 99999


class ConversionError(ValueError):
    """A moveit_msgs message that has no meaning for the planner (says which field and why)."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


def pose_from_msg(msg: Any) -> dict[str, list[float]]:
    p, q = msg.position, msg.orientation
    return {"position": [p.x, p.y, p.z], "orientation": [q.x, q.y, q.z, q.w]}


def _byte(value: Any) -> int:
    """A ROS ``byte`` field (bytes of length 1 in rclpy) as an int."""
    return value[0] if isinstance(value, (bytes, bytearray)) else int(value)


def _primitive_from_msg(msg: Any) -> dict[str, Any]:
    return {"type": int(msg.type), "dimensions": [float(d) for d in msg.dimensions]}


def _mesh_from_msg(msg: Any) -> dict[str, Any]:
    return {"vertices": [[v.x, v.y, v.z] for v in msg.vertices],
            "triangles": [[int(i) for i in t.vertex_indices] for t in msg.triangles]}


def collision_object_from_msg(msg: Any) -> dict[str, Any]:
    if len(msg.planes):
        raise ConversionError(FAILURE,
                              f"collision object '{msg.id}': planes are not supported; use a thin box")
    data: dict[str, Any] = {
        "id": msg.id,
        "frame_id": msg.header.frame_id or "world",
        "pose": pose_from_msg(msg.pose),
        "primitives": [_primitive_from_msg(p) for p in msg.primitives],
        "primitive_poses": [pose_from_msg(p) for p in msg.primitive_poses],
        "meshes": [_mesh_from_msg(m) for m in msg.meshes],
        "mesh_poses": [pose_from_msg(p) for p in msg.mesh_poses],
        "operation": _byte(msg.operation),
    }
    unset = data["pose"]["position"] == [0.0, 0.0, 0.0] and \
        data["pose"]["orientation"] in ([0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])
    if unset and len(data["primitives"]) + len(data["meshes"]) == 1:
        # MoveIt (PlanningScene::shapesAndPosesFromCollisionObjectMessage): an object of one shape
        # whose pose is unset lies at the shape's pose, the shape at the object's origin, so the
        # object's frame (for frames, grasps, constraints on the object) is the shape's. MoveIt
        # calls a pose unset when it is all zeros, as ROS 1 builds it; a ROS 2 Pose() has w = 1,
        # so the identity at the origin counts as unset too (MTC's ROS 1 demo scripts, ported
        # unchanged to ROS 2, rely on it: constrained.py constrains such an object's orientation).
        shapes, poses = ("primitives", "primitive_poses") if data["primitives"] else ("meshes", "mesh_poses")
        if data[poses]:
            data["pose"] = data[poses][0]
            data[poses][0] = {"position": [0.0, 0.0, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0]}
    if data["pose"]["orientation"] == [0.0, 0.0, 0.0, 0.0]:
        data["pose"]["orientation"] = [0.0, 0.0, 0.0, 1.0]  # an unset quaternion, as MoveIt reads it
    for shapes, poses in (("primitives", "primitive_poses"), ("meshes", "mesh_poses")):
        for pose in data[poses]:
            if pose["orientation"] == [0.0, 0.0, 0.0, 0.0]:
                pose["orientation"] = [0.0, 0.0, 0.0, 1.0]
        # MoveIt places a shape without a pose of its own at the object's pose
        while len(data[poses]) < len(data[shapes]):
            data[poses].append({"position": [0.0, 0.0, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0]})
    return data
