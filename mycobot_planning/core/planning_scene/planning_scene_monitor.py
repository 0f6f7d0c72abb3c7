"""The monitored planning scene without ROS (MoveIt's planning scene monitor and current state
monitor): the scene, the robot's current state fed from /joint_states with its age, and scene
updates that are checked completely before anything changes."""
from __future__ import annotations

import math
import threading
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from interfaces_py.msgs import (
    AttachedCollisionObject,
    CollisionObject,
    MessageError,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    PlanningSceneWorld,
)

from ..errors import PlanningError, RobotModelError, SceneError, StateError
from .planning_scene import PlanningScene
from ..robot_model.robot_model import RobotModel

__all__ = ["BAD_REQUEST", "CURRENT_STATE_WAIT", "PlanningSceneMonitor", "RequestError", "START_STATE_LIMIT_TOLERANCE"]

#: Error code of a refused scene request (the JSON-RPC face's "bad request").
BAD_REQUEST = -1001
#: rad: a start state may lie this far outside a joint limit (the controllers' readback noise).
START_STATE_LIMIT_TOLERANCE = 1e-4
#: Seconds a request waits for the first /joint_states message (MoveIt's waitForCurrentRobotState: 1 s).
CURRENT_STATE_WAIT = 1.0


class RequestError(PlanningError, ValueError):
    """A request the server refuses, with the code to answer (MoveIt's or BAD_REQUEST)."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message

    @property
    def moveit_code(self) -> int:
        """The code on MoveIt's face: ``code`` when it is a MoveItErrorCodes value, else (the JSON
        face's BAD_REQUEST) INVALID_MOTION_PLAN, "the request is invalid": a refused input is
        never FAILURE (99999, what an internal error answers)."""
        return self.code if MoveItErrorCode.is_known(self.code) else MoveItErrorCode.INVALID_MOTION_PLAN


class PlanningSceneMonitor:
    """The live scene and current state, guarded by one lock; ``scene_listeners`` are called after
    every applied update (the node publishes the monitored scene from them)."""

    #: s: a current state older than this is stale (the move_group capabilities take it from
    #: trajectory_execution's settings).
    joint_state_timeout: float = 1.0

    def __init__(self, model: RobotModel, clock: Callable[[], float], log: Callable[[str, str], None] | None = None) -> None:
        self.model = model
        self._clock = clock
        self._log = log or (lambda level, text: None)
        self._lock = threading.RLock()
        self.scene = PlanningScene(model)
        self._joint_values: dict[str, float] = {}
        self._joint_stamp: float | None = None
        self._first_joint_state = threading.Event()
        self._name_cache: dict[tuple[str, ...], tuple[np.ndarray, np.ndarray]] = {}
        self.scene_listeners: list[Callable[[], None]] = []

    def _joint_state_arrived(self) -> None:
        """Called after each applied joint state (execution monitoring wakes up on it)."""

    # ------------------------------------------------------------------ joint states
    def update_joint_state(self, names: Sequence[str], positions: Sequence[float]) -> str | None:
        """Take one /joint_states message. Returns why it was ignored (or None when applied).

        Joints the robot does not have are ignored (other robots may share the topic); mimic
        joints are kept for execution monitoring but the scene derives them from their source.
        """
        key = tuple(names)
        if len(positions) != len(key):
            return f"joint state has {len(key)} names but {len(positions)} positions"
        values = np.asarray(positions, dtype=float)
        if not np.all(np.isfinite(values)):
            bad = [n for n, v in zip(key, values) if not math.isfinite(v)]
            return f"joint state contains NaN or infinite positions for {bad}"
        mapping = self._name_cache.get(key)
        if mapping is None:
            index = {n: i for i, n in enumerate(self.model.variable_names)}
            sel = [i for i, n in enumerate(key) if n in index]
            mapping = (np.array(sel, dtype=int), np.array([index[key[i]] for i in sel], dtype=int))
            if len(self._name_cache) > 16:
                self._name_cache.clear()
            self._name_cache[key] = mapping
        sel, target = mapping
        with self._lock:
            self._joint_values.update(zip(key, values.tolist()))
            self._joint_stamp = self._clock()
            if not self._first_joint_state.is_set():  # set() takes a lock: once is enough
                self._first_joint_state.set()
            if sel.size:
                current = self.scene.current_state.positions
                if not np.array_equal(current[target], values[sel]):
                    new = current.copy()
                    new[target] = values[sel]
                    self.scene.set_current_state(new)
        self._joint_state_arrived()
        return None

    def joint_positions(self) -> tuple[dict[str, float] | None, float | None]:
        """(positions by joint name, age in s) of the latest joint states; (None, None) before any."""
        with self._lock:
            if self._joint_stamp is None:
                return None, None
            return dict(self._joint_values), self._clock() - self._joint_stamp

    def joint_state_problem(self, joints: Sequence[str]) -> tuple[int, str] | None:
        """Why the current state cannot be used for ``joints`` (code, message), or None.

        Before the first /joint_states message it waits up to CURRENT_STATE_WAIT for one, as
        move_group's waitForCurrentRobotState does: a request that arrives right after start-up
        would otherwise fail on discovery timing."""
        positions, age = self.joint_positions()
        if positions is None and self._first_joint_state.wait(CURRENT_STATE_WAIT):
            positions, age = self.joint_positions()
        if positions is None:
            return (MoveItErrorCode.ROBOT_STATE_STALE,
                    "no joint state received on /joint_states yet: is the joint state broadcaster running?")
        if age > self.joint_state_timeout:
            return (MoveItErrorCode.ROBOT_STATE_STALE,
                    f"the current robot state is stale: the last /joint_states message is {age:.2f} s old "
                    f"(joint_state_timeout {self.joint_state_timeout} s)")
        missing = [j for j in joints if j not in positions]
        if missing:
            return MoveItErrorCode.INVALID_ROBOT_STATE, f"/joint_states does not report joints {missing}"
        return None

    # ------------------------------------------------------------------ scene
    @contextmanager
    def locked(self, write: bool = False) -> Iterator[PlanningScene]:
        """The live scene with the monitor's lock held (MoveIt's LockedPlanningSceneRO/RW): joint
        states and updates wait meanwhile. ``write``: the listeners hear of the change at the end."""
        with self._lock:
            yield self.scene
        if write:
            self._changed()

    def _changed(self) -> None:
        for listener in list(self.scene_listeners):
            try:
                listener()
            except Exception as exc:  # a publisher problem must not undo an applied update
                self._log("error", f"scene listener failed: {exc}")

    def scene_msg(self) -> PlanningSceneMsg:
        return self.scene_copy().get_planning_scene_msg()

    def scene_copy(self) -> PlanningScene:
        with self._lock:
            return self.scene.copy()

    def scene_snapshot(self) -> tuple[PlanningSceneMsg, list[CollisionObject]]:
        """The full scene message and the attached objects posed in the world frame at the
        current state, built under one lock (what the node publishes together)."""
        scene = self.scene_copy()  # cheap (shared immutable objects): messages are built outside the lock
        msg = scene.get_planning_scene_msg()
        attached = [scene.get_object(i) for i in scene.attached_object_ids()]
        return msg, attached

    def attached_snapshot(self) -> tuple[list[float], list[CollisionObject]]:
        """(current positions, attached objects in the world frame): what moves with the robot."""
        scene = self.scene_copy()
        return [float(v) for v in scene.current_state.positions], [scene.get_object(i) for i in scene.attached_object_ids()]

    def marker_objects(self) -> list[tuple[CollisionObject, bool]]:
        """Every object in the world frame at the current state, with whether it is attached."""
        scene = self.scene_copy()
        return [(obj, False) for obj in scene.world_objects()] + [(scene.get_object(i), True)
                                                                   for i in scene.attached_object_ids()]

    def has_attached_objects(self) -> bool:
        with self._lock:
            return bool(self.scene.attached_object_ids())

    def _scene_call(self, what: str, fn: Callable[[], Any]) -> Any:
        try:
            with self._lock:
                result = fn()
        except SceneError as exc:
            text = str(exc)
            code = MoveItErrorCode.INVALID_OBJECT_NAME if "unknown collision object" in text else BAD_REQUEST
            raise RequestError(code, text) from None
        except (MessageError, StateError, RobotModelError) as exc:
            raise RequestError(BAD_REQUEST, f"{what}: {exc}") from None
        self._log("info", what)
        self._changed()
        return result

    @staticmethod
    def _message(cls: type, value: Any, what: str) -> Any:
        try:
            if isinstance(value, cls):
                return value
            if isinstance(value, (str, bytes, bytearray)):
                return cls.from_json(value)
            return cls.from_dict(value)
        except MessageError as exc:
            raise RequestError(BAD_REQUEST, f"invalid {what}: {exc}") from None

    def apply_planning_scene(self, scene: Any) -> dict[str, Any]:
        """Apply a PlanningScene message (a diff when is_diff, else a full replacement)."""
        msg = self._checked_scene_msg(scene)
        self._scene_call(f"applied a planning scene {'diff' if msg.is_diff else '(full)'}",
                         lambda: self.scene.apply_planning_scene_msg(msg))
        return {"applied": True}

    def scene_with_diff(self, scene: Any, base: PlanningScene | None = None, check_acm: bool = True) -> PlanningScene:
        """A copy of the monitored scene (or of ``base``) with a PlanningScene message applied,
        checked as apply_planning_scene checks it (``check_acm`` False: ACM names that name
        nothing are let through, as task solutions carry them); the live scene is not touched
        (MoveIt's planning_options.planning_scene_diff: that goal's scene only). RequestError
        when refused."""
        msg = self._checked_scene_msg(scene, check_acm)
        copy = base.copy() if base is not None else self.scene_copy()
        try:
            copy.apply_planning_scene_msg(msg)
        except SceneError as exc:
            text = str(exc)
            code = MoveItErrorCode.INVALID_OBJECT_NAME if "unknown collision object" in text else BAD_REQUEST
            raise RequestError(code, text) from None
        except (MessageError, StateError, RobotModelError, ValueError) as exc:
            raise RequestError(BAD_REQUEST, f"planning scene: {exc}") from None
        return copy

    def _checked_scene_msg(self, scene: Any, check_acm: bool = True) -> PlanningSceneMsg:
        """The PlanningScene message of ``scene``, its robot state within the joint limits and its
        ACM naming only links, groups and objects (RequestError otherwise)."""
        msg = self._message(PlanningSceneMsg, scene, "planning scene")
        outside = self._limit_problems({n: v for n, v in msg.robot_state.joint_positions().items()
                                        if n in self.model.variable_names})
        if outside:
            raise RequestError(BAD_REQUEST, "planning scene robot_state is outside the joint limits: " + "; ".join(outside))
        unknown = self._unknown_acm_names(msg) if check_acm else []
        if unknown:
            raise RequestError(BAD_REQUEST, f"allowed collision matrix names {unknown}, which are neither links of "
                                            f"robot '{self.model.name}' nor collision objects of the scene")
        return msg

    def apply_collision_objects(self, objects: Sequence[Any]) -> dict[str, Any]:
        """Apply CollisionObjects (ADD/REMOVE/APPEND/MOVE) all or nothing."""
        if not isinstance(objects, (list, tuple)) or not objects:
            raise RequestError(BAD_REQUEST, "expected a non-empty list of collision objects")
        msgs = [self._message(CollisionObject, o, f"collision object {k}") for k, o in enumerate(objects)]
        diff = PlanningSceneMsg(world=PlanningSceneWorld(collision_objects=msgs), is_diff=True)
        summary = ", ".join(f"{m.operation_name} '{m.id}'" for m in msgs[:5]) + (" ..." if len(msgs) > 5 else "")
        self._scene_call(f"collision objects: {summary}", lambda: self.scene.apply_planning_scene_msg(diff))
        return {"applied": len(msgs), "ids": [m.id for m in msgs]}

    def unknown_acm_names(self, msg: PlanningSceneMsg, also_known: Any = ()) -> list[str]:
        """ACM names of ``msg`` that name nothing: not a link or group, not an object of the scene
        or of the message (or in ``also_known``: objects earlier diffs of a task solution add),
        and not already in the scene's matrix (MoveIt keeps entries of removed objects, so a
        scene read back and applied again must still be accepted)."""
        return [n for n in self._unknown_acm_names(msg) if n not in set(also_known)]

    def _unknown_acm_names(self, msg: PlanningSceneMsg) -> list[str]:
        acm = msg.allowed_collision_matrix
        names = set(acm.entry_names) | set(acm.default_entry_names)
        if not names:
            return []
        with self._lock:
            known = set(self.scene.world_object_ids()) | set(self.scene.attached_object_ids())
            known |= set(self.scene.acm.entry_names)
        known |= {o.id for o in msg.world.collision_objects}
        known |= {a.object.id for a in msg.robot_state.attached_collision_objects}
        return sorted(n for n in names if n not in known and not self.model.has_link(n)
                      and not self.model.has_group(n))

    def _limit_problems(self, values: Mapping[str, float]) -> list[str]:
        """'joint=value outside [low, high]' for each value beyond its joint's limits; a joint the
        robot does not have is a RequestError (INVALID_ROBOT_STATE), never a RobotModelError."""
        mimic = set(self.model.mimic_joint_names)  # derived from their source joints: not checked here
        unknown = [name for name in values if name not in self.model.variable_names and name not in mimic]
        if unknown:
            raise RequestError(MoveItErrorCode.INVALID_ROBOT_STATE,
                               f"the state names joints {unknown[:5]} that robot '{self.model.name}' does not have")
        outside = []
        for name, value in values.items():
            if name in mimic:
                continue
            i = self.model.variable_index(name)
            low, high = float(self.model.lower_limits[i]), float(self.model.upper_limits[i])
            if not (low - START_STATE_LIMIT_TOLERANCE <= value <= high + START_STATE_LIMIT_TOLERANCE):
                outside.append(f"{name}={value:.6g} outside [{low:.4f}, {high:.4f}]")
        return outside

    def apply_attached_collision_object(self, attached: Any) -> dict[str, Any]:
        msg = self._message(AttachedCollisionObject, attached, "attached collision object")
        self._scene_call(f"attached collision object {msg.object.operation_name} '{msg.object.id}' on '{msg.link_name}'",
                         lambda: self.scene.apply_attached_collision_object(msg))
        return {"applied": True}

    def default_attach_link(self) -> str:
        """The link objects attach to when none is given: the end effector's parent link."""
        effectors = list(self.model.end_effectors.values())
        if len(effectors) == 1:
            return effectors[0].parent_link
        raise RequestError(BAD_REQUEST, "link_name is required: the robot has "
                                        f"{len(effectors)} end effectors, so there is no default")

    def default_touch_links(self, link: str) -> list[str]:
        """Links that may touch an object attached to ``link``: the link and everything mounted
        below it in the kinematic tree (for the flange: the gripper base and fingers that hold
        the object). MoveIt's default is the link alone, which makes every grasped object collide
        with the gripper holding it."""
        model = self.model
        below = []
        for other in model.link_names:
            current = other
            while current is not None and current != link:
                joint = model.parent_joint(current)
                current = model.joint(joint).parent_link if joint is not None else None
            if current == link and other != link:
                below.append(other)
        return [link] + below

    def attach_object(self, object_id: Any, link_name: str | None = None, touch_links: Sequence[str] | None = None,
                      weight: float = 0.0) -> dict[str, Any]:
        if not isinstance(object_id, str) or not object_id:
            raise RequestError(BAD_REQUEST, "attach_object needs an 'object_id' string")
        link = link_name or self.default_attach_link()
        if touch_links is None:
            touch = self.default_touch_links(link) if self.model.has_link(link) else [link]
        elif isinstance(touch_links, (list, tuple)) and all(isinstance(t, str) for t in touch_links):
            touch = list(touch_links)
        else:
            raise RequestError(BAD_REQUEST, "touch_links must be a list of link or group names")
        if isinstance(weight, bool) or not isinstance(weight, (int, float)):
            raise RequestError(BAD_REQUEST, f"weight must be a number, got {weight!r}")
        self._scene_call(f"attached '{object_id}' to '{link}'",
                         lambda: self.scene.attach_object(object_id, link, touch, float(weight)))
        return {"attached": object_id, "link_name": link, "touch_links": touch}

    def detach_object(self, object_id: Any) -> dict[str, Any]:
        if not isinstance(object_id, str) or not object_id:
            raise RequestError(BAD_REQUEST, "detach_object needs an 'object_id' string")
        self._scene_call(f"detached '{object_id}'", lambda: self.scene.detach_object(object_id))
        return {"detached": object_id}

    def get_objects(self, ids: Sequence[str] | None = None) -> dict[str, Any]:
        """World objects (world frame), attached objects (in their link's frame) and the attached
        objects' current world poses. ``ids`` filters; unknown ids are simply absent."""
        if ids is not None and (not isinstance(ids, (list, tuple)) or not all(isinstance(i, str) for i in ids)):
            raise RequestError(BAD_REQUEST, "ids must be a list of object id strings")
        wanted = set(ids) if ids else None
        scene = self.scene_copy()
        world = {i: scene.get_object(i).to_dict() for i in scene.world_object_ids() if wanted is None or i in wanted}
        attached, poses = {}, {}
        for i in scene.attached_object_ids():
            if wanted is None or i in wanted:
                attached[i] = scene.get_attached_object(i).to_dict()
                poses[i] = scene.get_object(i).pose.to_dict()
        return {"objects": world, "attached_objects": attached, "attached_object_poses": poses}

