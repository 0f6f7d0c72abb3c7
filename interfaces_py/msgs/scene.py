"""moveit_msgs' planning-scene messages: collision objects, attached objects, the allowed collision matrix, robot state, world and scene."""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .base import MessageError, _Message, _require_len, _require_name, _require_unique_names
from .geometry import Mesh, Pose, SolidPrimitive, _as_pose


@dataclass
class CollisionObject(_Message):
    """moveit_msgs/CollisionObject: shapes placed at ``pose`` in ``frame_id``.

    Each shape's pose is relative to the object ``pose`` (MoveIt >= Noetic semantics), so
    moving the object means changing one pose. ``operation`` uses MoveIt's values: ADD
    replaces any object with the same id, APPEND adds shapes to it, REMOVE and MOVE ignore the
    shapes (MOVE takes the new ``pose``). ADD and APPEND must carry at least one shape.
    Planes and subframes of the MoveIt message are not supported.
    """

    id: str
    frame_id: str = "world"
    pose: Pose = field(default_factory=Pose)
    primitives: list[SolidPrimitive] = field(default_factory=list)
    primitive_poses: list[Pose] = field(default_factory=list)
    meshes: list[Mesh] = field(default_factory=list)
    mesh_poses: list[Pose] = field(default_factory=list)
    operation: int = 0

    ADD: ClassVar[int] = 0
    REMOVE: ClassVar[int] = 1
    APPEND: ClassVar[int] = 2
    MOVE: ClassVar[int] = 3
    _OPERATIONS: ClassVar[dict[int, str]] = {0: "ADD", 1: "REMOVE", 2: "APPEND", 3: "MOVE"}

    def _validate(self) -> None:
        _require_name("CollisionObject.id", self.id)
        _require_name("CollisionObject.frame_id", self.frame_id)
        if self.operation not in self._OPERATIONS:
            raise MessageError(
                "CollisionObject.operation",
                f"unknown operation {self.operation}; expected ADD(0), REMOVE(1), APPEND(2) or MOVE(3)",
            )
        if len(self.primitive_poses) != len(self.primitives):
            raise MessageError("CollisionObject.primitive_poses",
                               f"{len(self.primitive_poses)} poses for {len(self.primitives)} primitives")
        if len(self.mesh_poses) != len(self.meshes):
            raise MessageError("CollisionObject.mesh_poses",
                               f"{len(self.mesh_poses)} poses for {len(self.meshes)} meshes")
        if self.operation in (self.ADD, self.APPEND) and not self.primitives and not self.meshes:
            raise MessageError("CollisionObject.primitives",
                               f"{self.operation_name} needs at least one primitive or mesh")

    @property
    def operation_name(self) -> str:
        return self._OPERATIONS[self.operation]

    @classmethod
    def box(cls, id: str, size: Sequence[float], pose: Pose | np.ndarray | None = None,
            frame_id: str = "world") -> CollisionObject:
        """Box of ``size`` (x, y, z) centred at ``pose`` (Pose, 4x4 matrix or None = origin)."""
        _require_len("CollisionObject.box(size)", size, 3, "box sizes (x, y, z)")
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   primitives=[SolidPrimitive.box(*size)], primitive_poses=[Pose()])

    @classmethod
    def cylinder(cls, id: str, height: float, radius: float, pose: Pose | np.ndarray | None = None,
                 frame_id: str = "world") -> CollisionObject:
        """Cylinder along the local z axis, centred at ``pose``."""
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   primitives=[SolidPrimitive.cylinder(height, radius)], primitive_poses=[Pose()])

    @classmethod
    def sphere(cls, id: str, radius: float, pose: Pose | np.ndarray | None = None,
               frame_id: str = "world") -> CollisionObject:
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   primitives=[SolidPrimitive.sphere(radius)], primitive_poses=[Pose()])

    @classmethod
    def mesh(cls, id: str, resource: str, pose: Pose | np.ndarray | None = None,
             frame_id: str = "world", scale: Sequence[float] = (1.0, 1.0, 1.0)) -> CollisionObject:
        return cls(id=id, frame_id=frame_id, pose=_as_pose(pose, "CollisionObject.pose"),
                   meshes=[Mesh.from_file(resource, scale)], mesh_poses=[Pose()])


@dataclass
class AttachedCollisionObject(_Message):
    """moveit_msgs/AttachedCollisionObject: ``object`` rigidly attached to robot link ``link_name``.

    ``touch_links`` may collide with the object (the gripper fingers holding it); ``weight`` is
    kept for MoveIt compatibility (kg) and must be >= 0.
    """

    link_name: str
    object: CollisionObject
    touch_links: list[str] = field(default_factory=list)
    weight: float = 0.0

    def _validate(self) -> None:
        _require_name("AttachedCollisionObject.link_name", self.link_name)
        for i, link in enumerate(self.touch_links):
            _require_name(f"AttachedCollisionObject.touch_links[{i}]", link)
        if self.weight < 0:
            raise MessageError("AttachedCollisionObject.weight", f"must be >= 0, got {self.weight}")


@dataclass
class AllowedCollisionMatrix(_Message):
    """moveit_msgs/AllowedCollisionMatrix: which pairs of bodies may touch.

    ``entry_values[i][j]`` is True when ``entry_names[i]`` and ``entry_names[j]`` may collide;
    the matrix must be square and symmetric because collision is symmetric and an asymmetric
    matrix has no meaning. ``default_entry_*`` give a per-name fallback used when a pair has no
    explicit entry (True: that body may collide with anything), exactly as in MoveIt.
    """

    entry_names: list[str] = field(default_factory=list)
    entry_values: list[list[bool]] = field(default_factory=list)
    default_entry_names: list[str] = field(default_factory=list)
    default_entry_values: list[bool] = field(default_factory=list)

    def _validate(self) -> None:
        path = "AllowedCollisionMatrix"
        _require_unique_names(f"{path}.entry_names", self.entry_names)
        n = len(self.entry_names)
        _require_len(f"{path}.entry_values", self.entry_values, n, "rows (one per entry name)")
        for i, row in enumerate(self.entry_values):
            _require_len(f"{path}.entry_values[{i}]", row, n, "columns (one per entry name)")
        for i in range(n):
            for j in range(i + 1, n):
                if self.entry_values[i][j] != self.entry_values[j][i]:
                    raise MessageError(f"{path}.entry_values", "not symmetric for "
                                       f"('{self.entry_names[i]}', '{self.entry_names[j]}')")
        _require_unique_names(f"{path}.default_entry_names", self.default_entry_names)
        _require_len(f"{path}.default_entry_values", self.default_entry_values,
                     len(self.default_entry_names), "values (one per default entry name)")

    def is_allowed(self, a: str, b: str) -> bool:
        """MoveIt's lookup: the explicit entry if there is one, else either body's default."""
        names = self.entry_names
        if a in names and b in names:
            return self.entry_values[names.index(a)][names.index(b)]
        defaults = dict(zip(self.default_entry_names, self.default_entry_values))
        return defaults.get(a, False) or defaults.get(b, False)

    def set_allowed(self, a: str, b: str, allowed: bool = True) -> None:
        """Set the (a, b) entry symmetrically, adding names as needed (matrix stays valid)."""
        for name in (a, b):
            if not isinstance(name, str) or not name:
                raise MessageError("AllowedCollisionMatrix.entry_names", f"invalid name {name!r}")
            if name not in self.entry_names:
                self.entry_names.append(name)
                for row in self.entry_values:
                    row.append(False)
                self.entry_values.append([False] * len(self.entry_names))
        i, j = self.entry_names.index(a), self.entry_names.index(b)
        self.entry_values[i][j] = self.entry_values[j][i] = bool(allowed)


@dataclass
class RobotState(_Message):
    """moveit_msgs/RobotState: joint positions (and optional velocities) plus attached objects.

    The wire form of a robot state; ``mycobot_planning.core.RobotState`` is the computational
    one. ``velocities`` is empty or one per joint. ``is_diff`` marks a partial state to be
    merged into the current one, as in MoveIt.
    """

    joint_names: list[str] = field(default_factory=list)
    positions: list[float] = field(default_factory=list)
    velocities: list[float] = field(default_factory=list)
    attached_collision_objects: list[AttachedCollisionObject] = field(default_factory=list)
    is_diff: bool = False

    def _validate(self) -> None:
        _require_unique_names("RobotState.joint_names", self.joint_names)
        n = len(self.joint_names)
        _require_len("RobotState.positions", self.positions, n, "positions (one per joint name)")
        if self.velocities:
            _require_len("RobotState.velocities", self.velocities, n, "velocities (one per joint name, or none)")
        ids = [a.object.id for a in self.attached_collision_objects]
        if len(set(ids)) != len(ids):
            raise MessageError("RobotState.attached_collision_objects", "duplicate object id")

    def joint_positions(self) -> dict[str, float]:
        return dict(zip(self.joint_names, self.positions))

    @classmethod
    def from_joint_positions(cls, positions: Mapping[str, float], is_diff: bool = False) -> RobotState:
        return cls(joint_names=list(positions), positions=list(positions.values()), is_diff=is_diff)


@dataclass
class PlanningSceneWorld(_Message):
    """moveit_msgs/PlanningSceneWorld: the world (non-robot) collision objects."""

    collision_objects: list[CollisionObject] = field(default_factory=list)


@dataclass
class PlanningScene(_Message):
    """moveit_msgs/PlanningScene: robot state, world objects and ACM; a diff when ``is_diff``.

    Published as JSON on ``/monitored_planning_scene``; ``fixed_frame`` is the frame world
    objects are expressed in after the scene resolves them.
    """

    name: str = ""
    robot_model_name: str = ""
    fixed_frame: str = "world"
    robot_state: RobotState = field(default_factory=RobotState)
    world: PlanningSceneWorld = field(default_factory=PlanningSceneWorld)
    allowed_collision_matrix: AllowedCollisionMatrix = field(default_factory=AllowedCollisionMatrix)
    is_diff: bool = False
