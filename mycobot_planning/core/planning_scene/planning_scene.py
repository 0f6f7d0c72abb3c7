"""PlanningScene: the robot's current state, world collision objects, attached objects and the
allowed collision matrix — MoveIt's planning_scene::PlanningScene for this package.

The full story: docs/core.md, section mycobot_planning.core.planning_scene.
"""
from __future__ import annotations

import copy as _copy
import threading
import weakref
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from interfaces_py.pose_conversion import PoseError, pose_matrix
from interfaces_py.msgs import (
    AttachedCollisionObject,
    CollisionObject,
    Mesh,
    MessageError,
    PlanningScene as PlanningSceneMsg,
    PlanningSceneWorld,
    Pose,
    RobotState as RobotStateMsg,
    SolidPrimitive,
)

from ..collision_detection.acm import AllowedCollisionMatrix
from ..collision_detection.batch_check import BATCH_RULE_SAMPLES, numba_available, one_state_free
from ..collision_detection.collision import CompiledScene, RobotCollisionInfo
from ..collision_detection.collision_common import (
    OBJECT,
    ROBOT_ATTACHED,
    ROBOT_LINK,
    CollisionReport,
    Contact,
    DistanceReport,
)
from ..collision_detection.world import (
    AttachedBody,
    SceneObject,
    Shape,
    read_only,
    mesh_geometry,
    primitive_geometry,
)
from ..errors import RobotModelError, SceneError, StateError
from ..robot_model.robot_model import RobotModel
from ..robot_state.robot_state import RobotState
from ..transforms import inverse

__all__ = [
    "AllowedCollisionMatrix",
    "CollisionReport",
    "Contact",
    "DistanceReport",
    "OBJECT",
    "PlanningScene",
    "ROBOT_ATTACHED",
    "ROBOT_LINK",
]

_OPERATION_NAMES = {0: "ADD", 1: "REMOVE", 2: "APPEND", 3: "MOVE"}
_FLOAT64 = np.dtype(np.float64)  # compared by identity first in the per-state hot path


class _Slot:
    """Holder of a compiled collision model, shared by scene copies until one of them changes."""

    __slots__ = ("value",)

    def __init__(self, value: CompiledScene | None = None) -> None:
        self.value = value


class _CompiledScenes:
    """The last few compiled collision models by content: the robot, the world and attached
    objects (by identity: they are immutable and shared by scene copies) in their order, and
    the allowed collisions. Scenes that reach the same content by different edits (a task
    allowing the same collision in each of its branches' scene copies) share one compiled
    model, as copies of one scene do, instead of compiling it again. The entries keep what
    their keys name alive, so an identity in a key is never reused while the entry lives."""

    SIZE = 8

    def __init__(self) -> None:
        self._entries: dict[tuple, tuple[CompiledScene, tuple]] = {}
        self._lock = threading.Lock()

    @staticmethod
    def key(robot: RobotCollisionInfo, world: Mapping[str, SceneObject], attached: Mapping[str, AttachedBody],
            acm: AllowedCollisionMatrix) -> tuple:
        return (id(robot), tuple((name, id(obj)) for name, obj in world.items()),
                tuple((name, id(body)) for name, body in attached.items()),
                frozenset(acm.entries().items()), frozenset(acm.defaults().items()))

    def get(self, robot: RobotCollisionInfo, world: Mapping[str, SceneObject],
            attached: Mapping[str, AttachedBody], acm: AllowedCollisionMatrix) -> CompiledScene:
        key = self.key(robot, world, attached, acm)
        with self._lock:
            entry = self._entries.pop(key, None)
            if entry is not None:
                self._entries[key] = entry  # most recently used last
                return entry[0]
        compiled = CompiledScene(robot, world, attached, acm)
        with self._lock:
            self._entries[key] = (compiled, (robot, tuple(world.values()), tuple(attached.values())))
            while len(self._entries) > self.SIZE:
                self._entries.pop(next(iter(self._entries)))
        return compiled


_COMPILED_SCENES = _CompiledScenes()


@dataclass(frozen=True)
class _Snapshot:
    """What a diff() child remembers of its parent, to report only its own changes."""

    world: dict
    attached: dict
    acm: AllowedCollisionMatrix
    positions: np.ndarray


def _as_message(value: Any, cls: type, what: str):
    """A message instance from an instance, a dict or JSON text; MessageError -> SceneError."""
    if isinstance(value, cls):
        return value
    try:
        if isinstance(value, Mapping):
            return cls.from_dict(value)
        if isinstance(value, (str, bytes, bytearray)):
            return cls.from_json(value)
    except MessageError as exc:
        raise SceneError(f"invalid {what}: {exc}") from None
    raise SceneError(f"expected a {cls.__name__} (or its dict/JSON form) for {what}, got {type(value).__name__}")


def _pose_matrix(pose: Any, what: str) -> np.ndarray:
    """The pose as a 4x4 (interfaces_py.pose_conversion), a bad one refused as a SceneError."""
    try:
        return pose_matrix(pose, what)
    except PoseError as exc:
        raise SceneError(str(exc)) from None


def _pose_msg(matrix: np.ndarray) -> Pose:
    return Pose.from_matrix(matrix)


class PlanningScene:
    """Robot state + world objects + attached objects + allowed collisions, with fast checks."""

    def __init__(self, model: RobotModel, state: RobotState | np.ndarray | Sequence[float] | None = None, name: str = "") -> None:
        self._model = model
        self._robot = RobotCollisionInfo.for_model(model)
        self.name = name
        self._state = RobotState(model) if state is None else self._coerce_state(state)
        self._world: dict[str, SceneObject] = {}
        self._attached: dict[str, AttachedBody] = {}
        self._acm = AllowedCollisionMatrix(model)
        self._slot = _Slot()
        self._parent: _Snapshot | None = None
        self._listen(self._acm)

    @classmethod
    def from_msg(cls, model: RobotModel, msg: PlanningSceneMsg | Mapping | str) -> "PlanningScene":
        """A scene built from a (full) planning scene message."""
        scene = cls(model)
        scene.apply_planning_scene_msg(msg)
        return scene

    # ------------------------------------------------------------------ basics
    @property
    def robot_model(self) -> RobotModel:
        return self._model

    @property
    def model(self) -> RobotModel:
        return self._model

    @property
    def current_state(self) -> RobotState:
        """The scene's robot state (the object itself; set_current_state replaces it)."""
        return self._state

    def set_current_state(self, state: RobotState | np.ndarray | Sequence[float] | Mapping[str, float]) -> None:
        """Replace the current state (a RobotState, a full position vector, or a dict of some joints)."""
        if isinstance(state, Mapping):
            new = self._state.copy()
            new.set_joint_positions(state)
            self._state = new
        else:
            self._state = self._coerce_state(state)

    def _coerce_state(self, state: Any) -> RobotState:
        if isinstance(state, RobotState):
            return self._own_state(state).copy()
        return RobotState(self._model, state)

    def _state_or_current(self, state: RobotState | None) -> RobotState:
        if state is None:
            return self._state
        if not isinstance(state, RobotState):
            return self._coerce_state(state)
        return self._own_state(state)

    def _own_state(self, state: RobotState) -> RobotState:
        """``state`` itself; a SceneError when it belongs to another robot than the scene's."""
        if state.model is not self._model:
            raise SceneError(
                f"robot state belongs to robot '{state.model.name}', not to this scene's robot '{self._model.name}'"
            )
        return state

    @property
    def acm(self) -> AllowedCollisionMatrix:
        """The allowed collision matrix; changing it updates what the scene checks."""
        return self._acm

    @property
    def allowed_collision_matrix(self) -> AllowedCollisionMatrix:
        return self._acm

    def _listen(self, acm: AllowedCollisionMatrix) -> None:
        ref = weakref.ref(self)

        def invalidate() -> None:
            scene = ref()
            if scene is not None:
                scene._slot = _Slot()

        acm._set_listener(invalidate)

    def _changed(self) -> None:
        self._slot = _Slot()

    @property
    def content_token(self) -> object:
        """An object that stays the same while the scene's world objects, attached objects and
        allowed collisions do (every change of them replaces it; copies share it until then): the
        key of a cache of anything built from them. The robot's positions are not part of it."""
        return self._slot

    # ------------------------------------------------------------------ copies
    def copy(self) -> "PlanningScene":
        """Independent scene sharing the (immutable) objects and the compiled collision model."""
        clone = PlanningScene.__new__(PlanningScene)
        clone._model = self._model
        clone._robot = self._robot
        clone.name = self.name
        clone._state = self._state.copy()
        clone._world = dict(self._world)
        clone._attached = dict(self._attached)
        clone._acm = self._acm.copy()
        clone._slot = self._slot
        clone._parent = None
        clone._listen(clone._acm)
        return clone

    def diff(self) -> "PlanningScene":
        """A copy that remembers this scene as its parent: get_planning_scene_msg(diff=True) on it
        lists only the changes made since (MoveIt's PlanningScene::diff)."""
        child = self.copy()
        child._parent = _Snapshot(dict(self._world), dict(self._attached), self._acm.copy(), self._state.positions.copy())
        return child

    @property
    def has_parent(self) -> bool:
        return self._parent is not None

    def _adopt(self, staged: "PlanningScene") -> None:
        """Take over a staged copy's content (the commit step of an all-or-nothing update)."""
        self.name = staged.name
        self._state = staged._state
        self._world = staged._world
        self._attached = staged._attached
        self._acm = staged._acm
        self._listen(self._acm)
        self._slot = staged._slot

    # ------------------------------------------------------------------ frames
    def frame_pose(self, frame_id: str, state: RobotState | None = None) -> np.ndarray:
        """World pose (4x4) of a robot link/frame, 'world', or a collision object (world or attached)."""
        state = self._state_or_current(state)
        if not isinstance(frame_id, str) or not frame_id:
            raise SceneError(f"invalid frame_id {frame_id!r}")
        obj = self._world.get(frame_id)
        if obj is not None:
            return np.array(obj.pose)
        body = self._attached.get(frame_id)
        if body is not None:
            return state.frame_pose(body.link) @ body.object.pose
        try:
            self._model.frame_id(frame_id)
        except RobotModelError:
            raise SceneError(
                f"unknown frame_id '{frame_id}': not 'world', a link of robot '{self._model.name}' "
                "or a collision object id"
            ) from None
        return state.frame_pose(frame_id)

    # ------------------------------------------------------------------ world objects
    def world_object_ids(self) -> list[str]:
        return list(self._world)

    def attached_object_ids(self) -> list[str]:
        return list(self._attached)

    def world_geometry(self) -> list[SceneObject]:
        """The world objects as compiled for checking (immutable: id, world pose, Coal shapes),
        for consumers of the geometry itself (a distance field)."""
        return list(self._world.values())

    def attached_bodies(self) -> list[AttachedBody]:
        """The attached objects as compiled for checking (immutable: shapes posed in their link)."""
        return list(self._attached.values())

    def has_object(self, object_id: str) -> bool:
        """True for a world object or an attached object with this id."""
        return object_id in self._world or object_id in self._attached

    def is_attached(self, object_id: str) -> bool:
        return object_id in self._attached

    def _check_new_id(self, object_id: str, what: str) -> None:
        if not isinstance(object_id, str) or not object_id:
            raise SceneError(f"{what}: object id must be a non-empty string, got {object_id!r}")
        if self._model.has_link(object_id):
            raise SceneError(f"{what}: id '{object_id}' is the name of a robot link; choose another id")
        if self._model.has_group(object_id):
            raise SceneError(f"{what}: id '{object_id}' is the name of a planning group; choose another id")

    def _unknown_object(self, object_id: str, what: str) -> SceneError:
        known = ", ".join(f"'{i}'" for i in list(self._world) + list(self._attached)) or "none"
        return SceneError(f"{what}: unknown collision object '{object_id}' (known: {known})")

    def _shapes_from_msg(self, msg: CollisionObject, what: str) -> list[Shape]:
        primitives, primitive_poses = list(msg.primitives), list(msg.primitive_poses)
        meshes, mesh_poses = list(msg.meshes), list(msg.mesh_poses)
        if len(primitive_poses) != len(primitives):
            raise SceneError(f"{what}: {len(primitive_poses)} primitive_poses for {len(primitives)} primitives")
        if len(mesh_poses) != len(meshes):
            raise SceneError(f"{what}: {len(mesh_poses)} mesh_poses for {len(meshes)} meshes")
        if not primitives and not meshes:
            raise SceneError(f"{what}: needs at least one primitive or mesh")
        shapes = []
        for k, (primitive, pose) in enumerate(zip(primitives, primitive_poses)):
            where = f"{what}: primitive {k}"
            if not isinstance(primitive, SolidPrimitive):
                raise SceneError(f"{where}: expected a SolidPrimitive, got {type(primitive).__name__}")
            geometry = primitive_geometry(primitive, where)
            stored = SolidPrimitive(int(primitive.type), [float(d) for d in primitive.dimensions])
            shapes.append(Shape(geometry, read_only(_pose_matrix(pose, f"{where} pose")), primitive=stored))
        for k, (mesh, pose) in enumerate(zip(meshes, mesh_poses)):
            where = f"{what}: mesh {k}"
            if not isinstance(mesh, Mesh):
                raise SceneError(f"{where}: expected a Mesh, got {type(mesh).__name__}")
            geometry = mesh_geometry(mesh, where)
            shapes.append(Shape(geometry, read_only(_pose_matrix(pose, f"{where} pose")), mesh=_copy.deepcopy(mesh)))
        return shapes

    def _object_from_msg(self, msg: CollisionObject, what: str, state: RobotState | None = None) -> SceneObject:
        """A world-frame SceneObject from an ADD message (frame_id resolved at the given/current state)."""
        frame = self.frame_pose(msg.frame_id, state)
        pose = frame @ _pose_matrix(msg.pose, f"{what} pose")
        shapes = self._shapes_from_msg(msg, what)
        return SceneObject(msg.id, read_only(pose), tuple(shapes))

    def apply_collision_object(self, obj: CollisionObject | Mapping | str) -> None:
        """Apply a CollisionObject with MoveIt semantics: ADD (replaces an existing id), REMOVE,
        APPEND (adds shapes; creates the object if new) or MOVE (new pose, shapes ignored)."""
        msg = _as_message(obj, CollisionObject, "collision object")
        operation = msg.operation
        op_name = _OPERATION_NAMES.get(operation)
        if op_name is None:
            raise SceneError(f"collision object '{msg.id}': unknown operation {operation!r}")
        what = f"cannot {op_name} collision object '{msg.id}'"
        if not isinstance(msg.frame_id, str) or not msg.frame_id:
            raise SceneError(f"{what}: frame_id must be a non-empty string")
        if msg.id in self._attached:
            raise SceneError(
                f"{what}: it is attached to link '{self._attached[msg.id].link}'; "
                "detach it first (or use an AttachedCollisionObject)"
            )
        if operation == CollisionObject.ADD or (operation == CollisionObject.APPEND and msg.id not in self._world):
            self._check_new_id(msg.id, what)
            new = self._object_from_msg(msg, what)
            self._world[msg.id] = new
        elif operation == CollisionObject.REMOVE:
            if msg.id not in self._world:
                raise self._unknown_object(msg.id, what)
            del self._world[msg.id]
        elif operation == CollisionObject.APPEND:
            existing = self._world[msg.id]
            frame = self.frame_pose(msg.frame_id)
            base = frame @ _pose_matrix(msg.pose, f"{what} pose")
            relative = inverse(np.asarray(existing.pose)) @ base
            shapes = [
                Shape(s.geometry, read_only(relative @ s.pose), s.primitive, s.mesh)
                for s in self._shapes_from_msg(msg, what)
            ]
            self._world[msg.id] = SceneObject(msg.id, existing.pose, existing.shapes + tuple(shapes))
        else:  # MOVE
            if msg.id not in self._world:
                raise self._unknown_object(msg.id, what)
            pose = self.frame_pose(msg.frame_id) @ _pose_matrix(msg.pose, f"{what} pose")
            self._world[msg.id] = self._world[msg.id].with_pose(pose)
        self._changed()

    def add_object(self, obj: CollisionObject | Mapping | str) -> None:
        """Add (or replace) a world object, whatever the message's operation field says."""
        msg = _as_message(obj, CollisionObject, "collision object")
        if msg.operation != CollisionObject.ADD:
            msg = _copy.copy(msg)
            msg.operation = CollisionObject.ADD
        self.apply_collision_object(msg)

    def remove_object(self, object_id: str) -> None:
        """Remove a world object (SceneError if unknown or attached)."""
        if object_id in self._attached:
            raise SceneError(
                f"cannot remove collision object '{object_id}': it is attached to link "
                f"'{self._attached[object_id].link}'; detach it first"
            )
        if object_id not in self._world:
            raise self._unknown_object(object_id, "cannot remove collision object")
        del self._world[object_id]
        self._changed()

    def remove_all_world_objects(self) -> None:
        if self._world:
            self._world.clear()
            self._changed()

    def move_object(self, object_id: str, pose: Pose | np.ndarray, frame_id: str = "world") -> None:
        """Place a world object at a new pose (given in frame_id), keeping its shapes."""
        what = f"cannot move collision object '{object_id}'"
        if object_id in self._attached:
            raise SceneError(f"{what}: it is attached to link '{self._attached[object_id].link}'")
        if object_id not in self._world:
            raise self._unknown_object(object_id, what)
        world_pose = self.frame_pose(frame_id) @ _pose_matrix(pose, f"{what} pose")
        self._world[object_id] = self._world[object_id].with_pose(world_pose)
        self._changed()

    def get_object(self, object_id: str) -> CollisionObject:
        """A world object as a CollisionObject in the world frame; an attached object posed at the
        current state (still in the world frame)."""
        obj = self._world.get(object_id)
        if obj is None:
            body = self._attached.get(object_id)
            if body is None:
                raise self._unknown_object(object_id, "cannot get collision object")
            obj = body.object.with_pose(self._state.frame_pose(body.link) @ body.object.pose)
        return self._object_msg(obj, "world")

    def world_objects(self) -> list[CollisionObject]:
        """Every world object as an ADD CollisionObject in the world frame."""
        return [self._object_msg(obj, "world") for obj in self._world.values()]

    @staticmethod
    def _object_msg(obj: SceneObject, frame_id: str) -> CollisionObject:
        primitives, primitive_poses, meshes, mesh_poses = [], [], [], []
        for shape in obj.shapes:
            if shape.primitive is not None:
                primitives.append(SolidPrimitive(shape.primitive.type, list(shape.primitive.dimensions)))
                primitive_poses.append(_pose_msg(shape.pose))
            elif shape.mesh is not None:
                meshes.append(_copy.deepcopy(shape.mesh))
                mesh_poses.append(_pose_msg(shape.pose))
        return CollisionObject(
            id=obj.id,
            frame_id=frame_id,
            pose=_pose_msg(obj.pose),
            primitives=primitives,
            primitive_poses=primitive_poses,
            meshes=meshes,
            mesh_poses=mesh_poses,
            operation=CollisionObject.ADD,
        )

    # ------------------------------------------------------------------ attached objects
    def _touch_links(self, touch_links: Iterable[str] | str, what: str) -> frozenset[str]:
        if isinstance(touch_links, str):
            touch_links = [touch_links]
        names = self._acm.expand(list(touch_links))
        unknown = [n for n in names if not self._model.has_link(n)]
        if unknown:
            raise SceneError(f"{what}: touch links {unknown} are not links (or groups) of robot '{self._model.name}'")
        return frozenset(names)

    def _check_link(self, link: str, what: str) -> None:
        if not isinstance(link, str) or not self._model.has_link(link):
            raise SceneError(f"{what}: unknown link {link!r} of robot '{self._model.name}'")

    def attach_object(
        self, object_id: str, link: str, touch_links: Iterable[str] | str = (), weight: float = 0.0
    ) -> None:
        """Attach a world object (or re-attach an attached one) to a link, keeping its current
        world pose; touch_links (links or group names) may touch it, the link itself always may."""
        what = f"cannot attach collision object '{object_id}'"
        self._check_link(link, what)
        touch = self._touch_links(touch_links, what)
        if not np.isfinite(weight) or weight < 0:
            raise SceneError(f"{what}: weight must be >= 0, got {weight}")
        if object_id in self._world:
            world_pose = np.asarray(self._world[object_id].pose)
            source = self._world[object_id]
        elif object_id in self._attached:
            body = self._attached[object_id]
            world_pose = self._state.frame_pose(body.link) @ body.object.pose
            source = body.object
        else:
            raise self._unknown_object(object_id, what)
        relative = inverse(self._state.frame_pose(link)) @ world_pose
        self._world.pop(object_id, None)
        self._attached[object_id] = AttachedBody(source.with_pose(relative), link, touch, float(weight))
        self._changed()

    def detach_object(self, object_id: str) -> None:
        """Put an attached object back into the world where it is now (at the current state)."""
        body = self._attached.get(object_id)
        if body is None:
            if object_id in self._world:
                raise SceneError(f"cannot detach collision object '{object_id}': it is not attached (it is a world object)")
            raise self._unknown_object(object_id, "cannot detach collision object")
        world_pose = self._state.frame_pose(body.link) @ body.object.pose
        del self._attached[object_id]
        self._world[object_id] = body.object.with_pose(world_pose)
        self._changed()

    def apply_attached_collision_object(self, attached: AttachedCollisionObject | Mapping | str) -> None:
        """Apply an AttachedCollisionObject with MoveIt semantics: ADD attaches the message's
        object (replacing a world object of that id), APPEND adds shapes to an attached object,
        REMOVE detaches it back into the world at its current pose."""
        msg = _as_message(attached, AttachedCollisionObject, "attached collision object")
        obj = msg.object
        op_name = _OPERATION_NAMES.get(obj.operation, str(obj.operation))
        what = f"cannot {op_name} attached collision object '{obj.id}'"
        if obj.operation == CollisionObject.REMOVE:
            body = self._attached.get(obj.id)
            if body is None:
                raise SceneError(f"{what}: it is not attached")
            if msg.link_name and msg.link_name != body.link:
                raise SceneError(f"{what}: it is attached to link '{body.link}', not '{msg.link_name}'")
            self.detach_object(obj.id)
            return
        if obj.operation == CollisionObject.MOVE:
            raise SceneError(f"{what}: MOVE is not supported for attached objects (detach, move, attach)")
        self._check_link(msg.link_name, what)
        touch = self._touch_links(msg.touch_links, what)
        if not np.isfinite(msg.weight) or msg.weight < 0:
            raise SceneError(f"{what}: weight must be >= 0, got {msg.weight}")
        link_inverse = inverse(self._state.frame_pose(msg.link_name))
        if obj.operation == CollisionObject.APPEND and obj.id in self._attached:
            body = self._attached[obj.id]
            base = link_inverse @ self.frame_pose(obj.frame_id) @ _pose_matrix(obj.pose, f"{what} pose")
            relative = inverse(np.asarray(body.object.pose)) @ base
            shapes = tuple(
                Shape(s.geometry, read_only(relative @ s.pose), s.primitive, s.mesh)
                for s in self._shapes_from_msg(obj, what)
            )
            new_obj = SceneObject(obj.id, body.object.pose, body.object.shapes + shapes)
            self._attached[obj.id] = AttachedBody(new_obj, body.link, body.touch_links | touch, float(msg.weight))
            self._changed()
            return
        self._check_new_id(obj.id, what)
        world_obj = self._object_from_msg(obj, what)
        relative = link_inverse @ np.asarray(world_obj.pose)
        self._world.pop(obj.id, None)
        self._attached[obj.id] = AttachedBody(world_obj.with_pose(relative), msg.link_name, touch, float(msg.weight))
        self._changed()

    def get_attached_object(self, object_id: str) -> AttachedCollisionObject:
        """An attached object as an AttachedCollisionObject (object posed in its link's frame)."""
        body = self._attached.get(object_id)
        if body is None:
            raise SceneError(f"collision object '{object_id}' is not attached")
        return self._attached_msg(body)

    def get_attached_objects(self) -> list[AttachedCollisionObject]:
        return [self._attached_msg(body) for body in self._attached.values()]

    def _attached_msg(self, body: AttachedBody) -> AttachedCollisionObject:
        return AttachedCollisionObject(
            link_name=body.link,
            object=self._object_msg(body.object, body.link),
            touch_links=sorted(body.touch_links),
            weight=body.weight,
        )

    # ------------------------------------------------------------------ allowed collisions
    def allow_collisions(self, names_a: str | Iterable[str], names_b: str | Iterable[str] | None = None, allowed: bool = True) -> None:
        """Allow (or forbid, allowed=False) collisions between names_a and names_b (links, object
        ids or group names); names_b None means with everything."""
        if names_b is None:
            if allowed:
                self._acm.allow(names_a)
            else:
                self._acm.forbid(names_a)
        else:
            self._acm.set_entry(names_a, names_b, allowed)

    # ------------------------------------------------------------------ collision checking
    def _compiled(self) -> CompiledScene:
        compiled = self._slot.value
        if compiled is None:
            compiled = _COMPILED_SCENES.get(self._robot, self._world, self._attached, self._acm)
            self._slot.value = compiled
        return compiled

    def is_valid_positions(self, positions: np.ndarray) -> bool:
        """Planners' hot path: within joint limits and collision-free, for a vector over
        model.variable_names (no RobotState built). NaN is invalid."""
        compiled = self._slot.value
        if compiled is None:
            compiled = self._compiled()
        robot = self._robot
        if type(positions) is not np.ndarray or positions.dtype != np.float64:
            positions = np.asarray(positions, dtype=float)
        values = positions.tolist()
        if len(values) != len(robot.lower):
            raise StateError(f"expected {len(robot.lower)} joint positions, got {len(values)}")
        for value, low, high in zip(values, robot.lower, robot.upper):
            if not low <= value <= high:
                return False
        return not compiled.collides(robot.to_q(positions))

    def validity_checker(
        self,
        group: str | Sequence[int] | np.ndarray | None = None,
        reference_state: RobotState | None = None,
        check_bounds: bool = True,
        sphere_pretest: bool = True,
    ) -> Callable[[np.ndarray], bool]:
        """A ``f(values) -> bool`` for planners working in a group's variables (OMPL state
        validity): values fill the group's joints of reference_state (default: the current
        state, copied now) in a reused buffer, then is_valid_positions decides. Without a group,
        values are full position vectors; instead of a group name, the variable indices the
        values stand for may be given. The checker follows later changes of this scene.

        ``check_bounds=False`` tests collisions only, for callers whose values are within the
        joint limits by construction (OMPL samples and interpolates inside its bounded space;
        IK steps are clipped to the limits). Planners call this tens of thousands of times per
        plan, and the per-joint limit test in Python is a third of the cost around the C++ call.
        Then, for plain configuration slots, the one-state sphere test (batch_free_checker) runs
        first and a state it calls free is not checked exactly; ``sphere_pretest=False`` leaves it
        out, for callers that send it the states the batch test left undecided (an OMPL plan
        whose edges go through the batch test: measured, the pre-test there costs more than it
        saves).
        """
        if group is None:
            return self.is_valid_positions
        if isinstance(group, str):
            indices = self._model.group(group).variable_indices
        else:
            indices = np.asarray(group, dtype=int)
        full = np.array(self._state_or_current(reference_state).positions, dtype=float)
        collides = self._group_collision_test(indices, full)
        if not check_bounds:
            slots = self._model.q_slots(indices)
            if slots is not None:
                q = np.array(self._robot.to_q(full), dtype=float)

                def collision_free(values: np.ndarray) -> bool:
                    q[slots] = values
                    return not collides(q)

                # the sphere test first (~2 µs, most free states end there), the exact check for
                # the states it leaves undecided, in one Python call
                sphere_then_exact = self.batch_free_checker(
                    indices, self._state_or_current(reference_state), one_state=True,
                    otherwise=collision_free) if sphere_pretest else None
                return sphere_then_exact if sphere_then_exact is not None else collision_free
        robot = self._robot
        to_q = robot.to_q
        lower, upper = robot.lower, robot.upper
        bounds = [(lower[i], upper[i]) for i in indices.tolist()] if check_bounds else None
        if check_bounds:
            others = np.ones(len(full), dtype=bool)
            others[indices] = False
            if not all(low <= value <= high for value, low, high, other
                       in zip(full.tolist(), lower, upper, others.tolist()) if other):
                def outside_limits(values: np.ndarray) -> bool:
                    return False  # a joint the checker holds fixed is outside its limits

                return outside_limits

        def check(values: np.ndarray) -> bool:
            if type(values) is not np.ndarray or values.dtype != np.float64:
                values = np.asarray(values, dtype=float)
            if values.shape != (len(indices),):
                raise StateError(f"expected {len(indices)} joint positions, got {values.size}")
            if bounds is not None:
                for value, (low, high) in zip(values.tolist(), bounds):
                    if not low <= value <= high:
                        return False
            full[indices] = values
            return not collides(to_q(full))

        return check

    def batch_free_checker(
        self,
        group: str | Sequence[int] | np.ndarray,
        reference_state: RobotState | None = None,
        one_state: bool = False,
        otherwise: Callable[[np.ndarray], bool] | None = None,
    ) -> Callable[[np.ndarray], Any] | None:
        """``f(values) -> (N,) bool`` for (N, d) rows of a group's values in reference_state
        (default: the current state, copied now): True where a state is certainly collision-free
        by the batch sphere test (collision_detection/batch_check.py), False where it is
        undecided (ask validity_checker). Never True for a state the exact check finds in
        collision; joint limits are not considered. None when a group variable's map to the
        configuration is not affine (continuous joints) or numba is missing. Like
        validity_checker it follows later changes of this scene; on a scene without a batch
        path (a shape or joint it does not model, or one where it does not pay) every state is
        undecided. ``one_state=True``: ``f(values) -> bool`` for one float64 vector (one compiled
        call, about 2 µs: the pre-test validity_checker puts before the exact check); None
        also for groups that drive mimic followers. With ``otherwise`` (one state only) the
        answer for a state the test leaves undecided is ``otherwise(values)`` instead of False:
        validity_checker's whole check in one Python call."""
        if not numba_available():
            return None
        indices = self._model.group(group).variable_indices if isinstance(group, str) else np.asarray(group, dtype=int)
        if not len(indices):
            return None
        slots = self._model.q_slots(indices)
        full = np.array(self._state_or_current(reference_state).positions, dtype=float)
        q_matrix = self._robot.q_matrix
        if slots is None and q_matrix is None:
            return None  # continuous joints: no affine map to the configuration
        moving = self.moving_joints(indices)
        q_ref = np.array(self._robot.to_q(full), dtype=float)
        if slots is None:  # mimic followers: the rows become whole configurations through the affine map
            slots = np.arange(len(q_ref))
            rows = q_ref - q_matrix[:, indices] @ full[indices]  # the configuration without the group's share
            group_columns = np.ascontiguousarray(q_matrix[:, indices].T)
        else:
            rows = group_columns = None
        model = self._model

        def rule_sample() -> np.ndarray:
            """The random states of the group the rule that decides whether the test pays is
            judged on (the same ones for every scene of the model: drawn once per variable set;
            asked only when a test is built)."""
            def draw() -> np.ndarray:
                low = np.where(np.isfinite(model.lower_limits[indices]), model.lower_limits[indices], -np.pi)
                high = np.where(np.isfinite(model.upper_limits[indices]), model.upper_limits[indices], np.pi)
                return read_only(np.random.default_rng(7).uniform(low, high, (BATCH_RULE_SAMPLES, len(indices))))

            sample = np.array(model.cached(("batch_rule_sample", np.asarray(indices, dtype=int).tobytes()), draw))
            return sample if group_columns is None else sample @ group_columns + rows

        scene = self
        # (compiled scene, its batch test, the test's one-state tables), replaced as one
        last: list[Any] = [(None, None, None, None)]

        def current() -> Any:
            """The batch test of the scene's compiled model now (None: no batch path)."""
            compiled = scene._slot.value
            if compiled is None:
                compiled = scene._compiled()
            entry = last[0]
            if entry[0] is not compiled:
                check = compiled.batch_check(moving, q_ref, slots, rule_sample)
                entry = last[0] = (compiled, check, None if check is None else check.one_ints,
                                   None if check is None else check.one_floats)
            return entry[1]

        def free(values: np.ndarray) -> np.ndarray:
            check = current()
            if check is None:
                return np.zeros(len(values), dtype=bool)
            if group_columns is not None:
                values = np.asarray(values, dtype=float) @ group_columns + rows
            return check.free(values)

        if not one_state:
            return free
        if group_columns is not None:
            return None  # one state through the affine map costs more than it saves

        if otherwise is None:
            def undecided(values: np.ndarray) -> bool:
                return False
        else:
            undecided = otherwise

        ndarray, float64 = np.ndarray, _FLOAT64

        def free_one(values: np.ndarray) -> bool:
            # current() inlined, names bound in the closure and the compiled call made directly:
            # planners call this for every state (each attribute or global lookup is ~30 ns of ~3 µs);
            # the scene's slot is read each time: a change of the scene replaces it
            compiled = scene._slot.value
            entry = last[0]
            if compiled is None or entry[0] is not compiled:
                current()
                entry = last[0]
            if entry[1] is None or type(values) is not ndarray or (values.dtype is not float64
                                                                     and values.dtype != float64):
                return undecided(values)  # anything but a float64 vector: the exact check decides
            if one_state_free(values, entry[2], entry[3]):
                return True
            return undecided(values)

        return free_one

    def moving_joints(self, indices: np.ndarray) -> frozenset[int]:
        """The Pinocchio joints that move when these variables change: their own joints and the
        mimic followers they drive (what the group collision test may not hold fixed). A fact
        of the model alone: computed once per variable set (planners ask on every plan)."""
        indices = np.asarray(indices, dtype=int)
        model = self._model

        def compute() -> frozenset[int]:
            moving_v = set(np.flatnonzero(np.any(model.jacobian_map(indices) != 0.0, axis=1)).tolist())
            pin_model = model.pin_model
            return frozenset(
                j for j in range(1, pin_model.njoints)
                if moving_v.intersection(range(pin_model.idx_vs[j], pin_model.idx_vs[j] + pin_model.nvs[j]))
            )

        return model.cached(("moving_joints", indices.tobytes()), compute)

    def _group_collision_test(self, indices: np.ndarray, full: np.ndarray) -> Callable[[np.ndarray], bool]:
        """Collision test for configurations that differ from ``full`` only in ``indices``
        (CompiledScene.group_collides: the pairs no moving joint affects are decided once). It
        follows later changes of this scene: the compiled scene is replaced on every change, so
        it is looked up per call and the group test rebuilt when it differs. The group test
        writes buffers of the thread that built it, so each calling thread keeps its own."""
        moving = self.moving_joints(indices)
        q_ref = np.array(self._robot.to_q(full), dtype=float)
        scene = self
        local = threading.local()

        def collides(q: np.ndarray) -> bool:
            compiled = scene._slot.value
            if compiled is None:
                compiled = scene._compiled()
            last = getattr(local, "last", None)
            if last is None or compiled is not last[0]:
                last = local.last = (compiled, compiled.group_collides(moving, q_ref))
            return last[1](q)

        return collides

    def colliding_rows(
        self,
        group: str | Sequence[int] | np.ndarray,
        reference_state: RobotState | None,
        values: np.ndarray,
        order: np.ndarray | None = None,
        stop_at_first: bool = False,
        all_pairs: bool = False,
    ) -> np.ndarray:
        """Collision verdicts (True: in collision; joint limits not considered) for many states
        at once: each row of ``values`` fills the group's variables (a group name, or variable
        indices) of ``reference_state`` (default: the current state). The configurations are
        built in one NumPy step and each goes to the compiled scene in one call: what a
        trajectory check of hundreds of states costs is the collision checks themselves.

        ``order`` (row indices) is the order the rows are checked in; with ``stop_at_first`` the
        checks end at the first colliding row, which is then the only True (rows not reached
        are False).

        Without ``all_pairs`` the rows go through the group's collision test (as validity_checker):
        pairs whose path holds none of the given variables' joints are decided once.
        ``all_pairs=True`` decides with the plain exact check of every active pair (no broad phase,
        no pre-test, nothing decided once), the same verdicts at several times the cost: for a
        checker that must not share the one it judges (the trajectory validator as a judge).
        Without it, the rows first go to the batch sphere test in one call (batch_free_checker)
        and only the rows it leaves undecided to the group's test: the same verdicts."""
        values = np.asarray(values, dtype=float)
        if values.ndim != 2:
            raise StateError(f"expected a 2-D array of states, got shape {values.shape}")
        indices = self._model.group(group).variable_indices if isinstance(group, str) else np.asarray(group, dtype=int)
        if values.shape[1] != len(indices):
            raise StateError(f"expected {len(indices)} values per state, got {values.shape[1]}")
        full = np.array(self._state_or_current(reference_state).positions, dtype=float)
        if all_pairs:
            collides = self._compiled().collides_all_pairs
        else:  # the rows differ from full only in indices: the group test (pairs no index moves decided once)
            collides = self._group_collision_test(indices, full)
        count = values.shape[0]
        slots = self._model.q_slots(indices)
        if slots is not None:
            q = np.tile(np.asarray(self._robot.to_q(full), dtype=float), (count, 1))
            q[:, slots] = values
            check = collides
        else:
            q = np.tile(full, (count, 1))
            q[:, indices] = values
            to_q = self._robot.to_q

            def check(row: np.ndarray) -> bool:
                return collides(to_q(row))
        batch = None if all_pairs or slots is None or count < 2 else self.batch_free_checker(indices, reference_state)
        free = batch(values) if batch is not None else None
        if free is not None and free.all():
            return np.zeros(count, dtype=bool)
        if order is None and not stop_at_first:
            if free is None:
                return np.fromiter((check(row) for row in q), dtype=bool, count=count)
            return np.fromiter((not f and check(row) for row, f in zip(q, free.tolist())), dtype=bool, count=count)
        out = np.zeros(count, dtype=bool)
        for i in (range(count) if order is None else np.asarray(order, dtype=int).tolist()):
            if free is not None and free[i]:
                continue
            if check(q[i]):
                out[i] = True
                if stop_at_first:
                    break
        return out

    def is_state_valid(self, state: RobotState | None = None) -> bool:
        """MoveIt's validity for planners: joint limits respected and no collision."""
        state = self._state_or_current(state)
        return self.is_valid_positions(state.positions)

    def is_state_colliding(self, state: RobotState | None = None) -> bool:
        """Collision only (joint limits ignored), like MoveIt's isStateColliding."""
        state = self._state_or_current(state)
        compiled = self._compiled()
        return bool(compiled.collides(self._robot.to_q(np.asarray(state.positions, dtype=float))))

    def check_collision(
        self, state: RobotState | None = None, max_contacts: int | None = None, all_pairs: bool = False
    ) -> CollisionReport:
        """Collision verdict plus the contacts (every colliding pair, up to max_contacts).
        ``all_pairs=True``: the verdict is the plain exact check's (see colliding_rows)."""
        state = self._state_or_current(state)
        compiled = self._compiled()
        q = self._robot.to_q(np.asarray(state.positions, dtype=float))
        if not (compiled.collides_all_pairs if all_pairs else compiled.collides)(q):
            return CollisionReport(False, [])
        contacts = compiled.contacts(q, max_contacts)
        return CollisionReport(True, contacts)

    def distance(
        self,
        state: RobotState | None = None,
        *,
        include_self: bool = True,
        include_world: bool = True,
        links: str | Iterable[str] | None = None,
    ) -> DistanceReport:
        """Minimum distance over the pairs the ACM does not allow, and the minimum per robot body.

        include_self: robot-robot pairs (attached objects count as robot), MoveIt's distanceSelf;
        include_world: robot-versus-world-object pairs, MoveIt's distanceRobot. links (link names
        or group names) restricts to pairs involving those links or objects attached to them.
        """
        state = self._state_or_current(state)
        bodies = None
        if links is not None:
            names = self._acm.expand(links)
            unknown = [n for n in names if not self._model.has_link(n) and n not in self._attached]
            if unknown:
                raise SceneError(f"distance: {unknown} are not links, groups or attached objects of this scene")
            bodies = frozenset(names)
        compiled = self._compiled()
        q = self._robot.to_q(np.asarray(state.positions, dtype=float))
        return compiled.distance(q, bool(include_self), bool(include_world), bodies)

    def collision_pairs(self) -> list[tuple[str, str]]:
        """The body pairs checked per state (after the ACM), for debugging allowed collisions."""
        return self._compiled().pair_names(active_only=False)

    # ------------------------------------------------------------------ messages
    def get_planning_scene_msg(self, diff: bool = False) -> PlanningSceneMsg:
        """The scene as a PlanningScene message; diff=True lists only the changes since diff()."""
        if diff:
            return self._diff_msg()
        state_msg = RobotStateMsg(
            joint_names=list(self._model.variable_names),
            positions=[float(x) for x in self._state.positions],
            attached_collision_objects=self.get_attached_objects(),
            is_diff=False,
        )
        return PlanningSceneMsg(
            name=self.name,
            robot_model_name=self._model.name,
            fixed_frame="world",
            robot_state=state_msg,
            world=PlanningSceneWorld(collision_objects=self.world_objects()),
            allowed_collision_matrix=self._acm.to_msg(),
            is_diff=False,
        )

    def _diff_msg(self) -> PlanningSceneMsg:
        parent = self._parent
        if parent is None:
            raise SceneError("this scene has no parent to diff against; create it with scene.diff()")
        names, positions = [], []
        for name, old, new in zip(self._model.variable_names, parent.positions, self._state.positions):
            if old != new:
                names.append(name)
                positions.append(float(new))
        attached_msgs = []
        for object_id, body in self._attached.items():
            if parent.attached.get(object_id) is not body:
                attached_msgs.append(self._attached_msg(body))
        for object_id, body in parent.attached.items():
            if object_id not in self._attached:
                attached_msgs.append(
                    AttachedCollisionObject(
                        link_name=body.link,
                        object=CollisionObject(id=object_id, frame_id=body.link, operation=CollisionObject.REMOVE),
                    )
                )
        world_msgs = [
            self._object_msg(obj, "world")
            for object_id, obj in self._world.items()
            if parent.world.get(object_id) is not obj
        ]
        for object_id in list(parent.world) + list(parent.attached):
            if object_id not in self._world and object_id not in self._attached:
                world_msgs.append(CollisionObject(id=object_id, frame_id="world", operation=CollisionObject.REMOVE))
        acm_msg = self._acm.to_msg() if self._acm != parent.acm else None
        kwargs = {}
        if acm_msg is not None:
            kwargs["allowed_collision_matrix"] = acm_msg
        return PlanningSceneMsg(
            name=self.name,
            robot_model_name=self._model.name,
            fixed_frame="world",
            robot_state=RobotStateMsg(
                joint_names=names, positions=positions, attached_collision_objects=attached_msgs, is_diff=True
            ),
            world=PlanningSceneWorld(collision_objects=world_msgs),
            is_diff=True,
            **kwargs,
        )

    def apply_planning_scene_msg(self, msg: PlanningSceneMsg | Mapping | str) -> None:
        """Apply a PlanningScene message: a diff (is_diff) updates, a full one replaces.

        Order as in MoveIt: robot state (joints, then attached objects), ACM, world objects.
        A full message with an empty ACM keeps the SRDF's disabled pairs (an empty matrix would make
        every adjacent link pair collide). All or nothing: on error the scene is unchanged.
        """
        msg = _as_message(msg, PlanningSceneMsg, "planning scene message")
        if msg.robot_model_name and msg.robot_model_name != self._model.name:
            raise SceneError(
                f"planning scene message is for robot '{msg.robot_model_name}', this scene's robot is '{self._model.name}'"
            )
        if msg.is_diff:
            staged = self.copy()
        else:
            staged = PlanningScene(self._model)
        staged._parent = None
        if msg.name:
            staged.name = msg.name
        staged._apply_robot_state_msg(msg.robot_state, full=not msg.is_diff)
        acm_msg = msg.allowed_collision_matrix
        if acm_msg.entry_names or acm_msg.default_entry_names:
            acm = AllowedCollisionMatrix.from_msg(acm_msg, self._model)
            staged._acm = acm
            staged._listen(acm)
            staged._changed()
        for k, obj in enumerate(msg.world.collision_objects):
            staged.apply_collision_object(obj)
        parent = self._parent
        self._adopt(staged)
        self._parent = parent

    def _apply_robot_state_msg(self, state_msg: RobotStateMsg, full: bool) -> None:
        values = state_msg.joint_positions()
        mimic = set(self._model.mimic_joint_names)
        active = {}
        for name, value in values.items():
            if name in mimic:
                continue  # derived from its source joint
            try:
                self._model.variable_index(name)
            except RobotModelError:
                raise SceneError(
                    f"robot state names joint '{name}', which is not an active joint of robot '{self._model.name}'"
                ) from None
            active[name] = value
        if active:
            try:
                self.set_current_state(active)
            except StateError as exc:
                raise SceneError(f"invalid robot state in planning scene message: {exc}") from None
        if full or (not state_msg.is_diff and state_msg.attached_collision_objects):
            # A full robot state that lists attached objects lists all of them: drop the others.
            # (A non-diff state listing none only sets joints: dropping every attached object
            # because a sender forgot is_diff would be a silent, surprising loss.)
            for object_id in list(self._attached):
                del self._attached[object_id]
                self._changed()
        for attached in state_msg.attached_collision_objects:
            self.apply_attached_collision_object(attached)

    def __repr__(self) -> str:
        return (
            f"PlanningScene(robot='{self._model.name}', world={list(self._world)}, "
            f"attached={list(self._attached)}, acm={self._acm!r})"
        )

    def to_json(self) -> str:
        """The full scene message as JSON (what the planning_server publishes)."""
        return self.get_planning_scene_msg().to_json()
