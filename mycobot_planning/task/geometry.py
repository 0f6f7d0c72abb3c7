"""Stamped geometry for stage properties: PoseStamped, PointStamped, Vector3Stamped, TwistStamped.

MTC stages take geometry_msgs types (a pose in a frame, a direction in a frame). The task
layer must not import ROS, so these are small value classes with the same names and fields.
The converters also accept the obvious shorthands (a link name for an ik_frame, ``(frame,
vector)`` tuples) and, by duck typing, real geometry_msgs messages (anything with
``header.frame_id`` and the usual fields), so node code can pass ROS messages straight in.

Poses are 4x4 homogeneous matrices, as everywhere in ``mycobot_planning.core``.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Sequence

import numpy as np

from interfaces_py.pose_conversion import pose_matrix

from ..core.errors import SceneError
from ..core.planning_scene.planning_scene import PlanningScene
from ..core.robot_model.robot_model import RobotModel
from ..core.transforms import check_pose, make_pose

__all__ = [
    "PointStamped",
    "PoseStamped",
    "TwistStamped",
    "Vector3Stamped",
    "as_point_stamped",
    "as_pose_stamped",
    "as_twist_stamped",
    "as_vector3_stamped",
    "frame_transform",
]

WORLD_FRAMES = ("", "world")


def _vec3(value: Any, what: str) -> np.ndarray:
    if hasattr(value, "x") and hasattr(value, "y") and hasattr(value, "z"):
        value = (value.x, value.y, value.z)
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.size != 3:
        raise ValueError(f"{what} needs 3 values, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains NaN or infinite values")
    return arr


def _frame(value: Any, what: str) -> str:
    if not isinstance(value, str):
        raise ValueError(f"{what} frame_id must be a string, got {type(value).__name__}")
    return value


@dataclass(frozen=True, eq=False)
class PoseStamped:
    """A pose (4x4) expressed in ``frame_id`` ('' or 'world' = the planning frame)."""

    frame_id: str = ""
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        object.__setattr__(self, "frame_id", _frame(self.frame_id, "PoseStamped"))
        object.__setattr__(self, "pose", check_pose(self.pose, "PoseStamped.pose").copy())

    @classmethod
    def from_xyz_rpy(cls, frame_id: str, xyz: Sequence[float] = (0, 0, 0), rpy: Sequence[float] = (0, 0, 0)) -> "PoseStamped":
        return cls(frame_id, make_pose(xyz, rpy=rpy))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, PoseStamped) and other.frame_id == self.frame_id and np.array_equal(other.pose, self.pose)

    def __repr__(self) -> str:
        xyz = ", ".join(f"{v:.4g}" for v in self.pose[:3, 3])
        return f"PoseStamped(frame_id={self.frame_id!r}, xyz=({xyz}))"


class _StampedVectors:
    """A ``frame_id`` and 3-vectors (every other dataclass field): checked and converted when
    made, compared by value."""

    def __post_init__(self) -> None:
        kind = type(self).__name__
        object.__setattr__(self, "frame_id", _frame(self.frame_id, kind))  # type: ignore[attr-defined]
        for vector in fields(self)[1:]:  # type: ignore[arg-type]
            object.__setattr__(self, vector.name, _vec3(getattr(self, vector.name), f"{kind}.{vector.name}"))

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, type(self)) and other.frame_id == self.frame_id  # type: ignore[attr-defined]
                and all(np.array_equal(getattr(other, vector.name), getattr(self, vector.name))
                        for vector in fields(self)[1:]))  # type: ignore[arg-type]


@dataclass(frozen=True, eq=False)
class PointStamped(_StampedVectors):
    frame_id: str = ""
    point: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True, eq=False)
class Vector3Stamped(_StampedVectors):
    """A translation (m) expressed in ``frame_id``'s axes (MoveRelative's direction)."""

    frame_id: str = ""
    vector: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True, eq=False)
class TwistStamped(_StampedVectors):
    """A linear (m) and angular (rad, axis * angle) motion in ``frame_id``'s axes."""

    frame_id: str = ""
    linear: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular: np.ndarray = field(default_factory=lambda: np.zeros(3))


# ------------------------------------------------------------------ converters (property coercion)
def as_pose_stamped(value: Any) -> PoseStamped:
    """PoseStamped from a PoseStamped, a frame name (identity pose in it, e.g. an ik_frame
    link), ``(frame_id, 4x4)``, or a geometry_msgs/PoseStamped-like object."""
    if isinstance(value, PoseStamped):
        return value
    if isinstance(value, str):
        return PoseStamped(value, np.eye(4))
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
        return PoseStamped(value[0], value[1])
    header = getattr(value, "header", None)
    if header is not None and hasattr(value, "pose"):
        return PoseStamped(header.frame_id, pose_matrix(value.pose, "pose"))
    raise TypeError("expected a PoseStamped, a frame name or (frame_id, 4x4 pose)")


def _as_stamped_vector(value: Any, kind: type, vector: str, expected: str) -> Any:
    """A ``kind`` (PointStamped, Vector3Stamped) from itself, ``(frame_id, xyz)``, or a
    geometry_msgs message with a header and the field ``vector``; TypeError ``expected``."""
    if isinstance(value, kind):
        return value
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], str):
        return kind(value[0], value[1])
    header = getattr(value, "header", None)
    if header is not None and hasattr(value, vector):
        return kind(header.frame_id, getattr(value, vector))
    raise TypeError(expected)


def as_point_stamped(value: Any) -> PointStamped:
    return _as_stamped_vector(value, PointStamped, "point", "expected a PointStamped or (frame_id, xyz)")


def as_vector3_stamped(value: Any) -> Vector3Stamped:
    return _as_stamped_vector(value, Vector3Stamped, "vector", "expected a Vector3Stamped or (frame_id, xyz)")


def as_twist_stamped(value: Any) -> TwistStamped:
    if isinstance(value, TwistStamped):
        return value
    header = getattr(value, "header", None)
    twist = getattr(value, "twist", None)
    if header is not None and twist is not None:
        return TwistStamped(header.frame_id, twist.linear, twist.angular)
    raise TypeError("expected a TwistStamped")


def frame_transform(scene, frame_id: str, state=None) -> np.ndarray:
    """World pose of a frame: '' / 'world' (identity), a robot link, or a collision object
    (world or attached). Raises SceneError naming the frame when it is unknown."""
    if frame_id in WORLD_FRAMES:
        return np.eye(4)
    return scene.frame_pose(frame_id, state)


def rigidly_connected_link(scene, frame_id: str) -> str:
    """The robot link a frame moves with: the link itself, or the link an object is attached
    to. SceneError for world objects and unknown frames (they cannot be an ik_frame)."""
    model = scene.robot_model
    if model.has_link(frame_id):
        return frame_id
    if scene.is_attached(frame_id):
        return scene.get_attached_object(frame_id).link_name
    if scene.has_object(frame_id):
        raise SceneError(f"frame '{frame_id}' is a world object, not attached to the robot: it cannot be an ik_frame")
    raise SceneError(f"unknown frame '{frame_id}': not a link of robot '{model.name}' or an attached object")


def default_tip(model: RobotModel, group: str) -> str:
    """The link a group moves to reach poses: its end effector's parent link when the group
    carries an end effector (MoveIt's getOnlyOneEndEffectorTip), else the chain tip."""
    for eef in model.end_effectors.values():
        if eef.parent_group == group:
            return eef.parent_link
    return model.group(group).tip_link


def robot_tip_for_frame(ik_frame: PoseStamped | None, scene: PlanningScene, group: str) -> tuple[str, np.ndarray]:
    """MTC's utils::getRobotTipForFrame: the robot link to plan for and the world pose of the
    ik frame at the scene's current state. Raises SceneError for unknown or world frames."""
    state = scene.current_state
    if ik_frame is None:
        link = default_tip(scene.robot_model, group)
        return link, state.frame_pose(link)
    if not ik_frame.frame_id:
        raise SceneError("ik_frame needs a frame_id (a robot link or an attached object)")
    link = rigidly_connected_link(scene, ik_frame.frame_id)
    return link, frame_transform(scene, ik_frame.frame_id, state) @ ik_frame.pose
