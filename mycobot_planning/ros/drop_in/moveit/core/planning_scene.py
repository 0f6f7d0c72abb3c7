"""``moveit.core.planning_scene``: moveit_py's PlanningScene over the core PlanningScene.

``PlanningScene(robot_model)`` makes a scene of its own (MTC's fixed_state.py hands one to
FixedState); the scenes of MoveItPy's planning scene monitor (``read_only()``/``read_write()``)
are the monitored scene itself. Messages are moveit_msgs (CollisionObject, AttachedCollisionObject,
PlanningSceneWorld, RobotState, Constraints); a bad one raises ValueError naming the problem and
changes nothing.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np
import rclpy.logging
from moveit_msgs.msg import PlanningScene as PlanningSceneRosMsg
from moveit_msgs.msg import PlanningSceneWorld as PlanningSceneWorldRosMsg

from interfaces_py.moveit_conversions import (
    attached_object_from_msg,
    planning_scene_from_msg,
    planning_scene_to_msg,
    robot_state_from_msg,
)
from interfaces_py.msgs import AttachedCollisionObject, MessageError, PlanningScene as PlanningSceneMsg
from interfaces_py.ros_message_reading import ConversionError, collision_object_from_msg
from mycobot_planning.core.errors import PlanningError
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene as CorePlanningScene
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory

from .kinematic_constraints import constraints_satisfied
from .robot_model import RobotModel, core_model, robot_model
from .robot_state import RobotState, core_state

__all__ = ["PlanningScene", "core_scene"]

_LOG = rclpy.logging.get_logger("moveit.core.planning_scene")


class PlanningScene:
    """moveit_py's PlanningScene: ``PlanningScene(robot_model)``."""

    def __init__(self, robot_model: Any, world: Any = None) -> None:
        if world is not None:
            raise ValueError("a shared collision world is not supported: leave 'world' out and add objects "
                             "with apply_collision_object")
        self._scene = CorePlanningScene(core_model(robot_model))
        self._changed: Callable[[], None] = lambda: None

    @classmethod
    def _wrap(cls, scene: CorePlanningScene, changed: Callable[[], None] | None = None) -> "PlanningScene":
        """A view of ``scene`` itself; ``changed`` is called after every change (a monitor's)."""
        wrapper = cls.__new__(cls)
        wrapper._scene = scene
        wrapper._changed = changed or (lambda: None)
        return wrapper

    # ------------------------------------------------------------------ properties
    @property
    def name(self) -> str:
        return self._scene.name

    @name.setter
    def name(self, value: str) -> None:
        self._scene.name = str(value)

    @property
    def robot_model(self) -> RobotModel:
        return robot_model(self._scene.robot_model)

    @property
    def planning_frame(self) -> str:
        return self.robot_model.model_frame

    @property
    def current_state(self) -> RobotState:
        """The scene's own state: changing it changes the scene."""
        return RobotState._wrap(self._scene.current_state)

    @current_state.setter
    def current_state(self, state: Any) -> None:
        self.set_current_state(state)

    def set_current_state(self, robot_state: Any) -> None:
        """A RobotState, or a moveit_msgs/RobotState (joints it names change, the rest stay)."""
        if isinstance(robot_state, (RobotState,)) or not hasattr(robot_state, "joint_state"):
            self._scene.set_current_state(core_state(robot_state))
        else:
            data = self._read(lambda: robot_state_from_msg(robot_state), "robot state")
            if data is not None:
                values = dict(zip(data["joint_names"], data["positions"]))
                self._apply(lambda: self._scene.set_current_state(
                    {k: v for k, v in values.items() if k in self._scene.robot_model.variable_names}))
        self._changed()

    @property
    def allowed_collision_matrix(self) -> Any:
        return self._scene.allowed_collision_matrix

    @property
    def planning_scene_message(self) -> PlanningSceneRosMsg:
        return planning_scene_to_msg(self._scene.get_planning_scene_msg().to_dict())

    @property
    def transforms(self) -> dict[str, np.ndarray]:
        """Poses of the world objects in the planning frame (a read-only snapshot)."""
        return {obj.id: self._scene.frame_pose(obj.id) for obj in self._scene.world_objects()}

    # ------------------------------------------------------------------ changing the scene
    @staticmethod
    def _read(convert: Callable[[], Any], what: str) -> Any:
        try:
            return convert()
        except (ConversionError, MessageError, ValueError, TypeError, AttributeError) as exc:
            raise ValueError(f"invalid {what}: {exc}") from None

    def _apply(self, change: Callable[[], Any]) -> None:
        try:
            change()
        except (PlanningError, MessageError) as exc:
            raise ValueError(str(exc)) from None
        self._changed()

    def apply_collision_object(self, collision_object_msg: Any, color_msg: Any = None) -> None:
        """A moveit_msgs/CollisionObject (ADD, REMOVE, APPEND, MOVE), all or nothing."""
        data = self._read(lambda: collision_object_from_msg(collision_object_msg), "collision object")
        diff = PlanningSceneMsg.from_dict({"is_diff": True, "world": {"collision_objects": [data]}})
        self._apply(lambda: self._scene.apply_planning_scene_msg(diff))

    def process_attached_collision_object(self, object: Any) -> None:  # noqa: A002 - moveit_py's keyword
        data = self._read(lambda: AttachedCollisionObject.from_dict(attached_object_from_msg(object)),
                          "attached collision object")
        self._apply(lambda: self._scene.apply_attached_collision_object(data))

    def process_planning_scene_world(self, msg: PlanningSceneWorldRosMsg) -> None:
        scene = PlanningSceneRosMsg(is_diff=True, world=msg)
        data = self._read(lambda: PlanningSceneMsg.from_dict(planning_scene_from_msg(scene)), "planning scene world")
        self._apply(lambda: self._scene.apply_planning_scene_msg(data))

    def remove_all_collision_objects(self) -> None:
        """Every world object (attached ones stay attached)."""
        self._apply(self._scene.remove_all_world_objects)

    # ------------------------------------------------------------------ checks
    def _state(self, robot_state: Any) -> Any:
        return self._scene.current_state if robot_state is None else core_state(robot_state)

    def _group_contacts(self, robot_state: Any, joint_model_group_name: str) -> list[Any]:
        """The contacts that involve the group's links (or objects attached to them)."""
        state = self._state(robot_state)
        report = self._scene.check_collision(state)
        if not report.collision:
            return []
        model = self._scene.robot_model
        if not joint_model_group_name:
            return list(report.contacts)
        links = set(model.group(joint_model_group_name).updated_link_names)
        for object_id in self._scene.attached_object_ids():
            if self._scene.get_attached_object(object_id).link_name in links:
                links.add(object_id)
        return [c for c in report.contacts if c.body_a in links or c.body_b in links]

    def is_state_colliding(self, *args: Any, robot_state: Any = None, joint_model_group_name: str = "",
                           verbose: bool = False) -> bool:
        """``(joint_model_group_name, verbose=False)`` for the current state, or ``(robot_state,
        joint_model_group_name, verbose=False)``: is a link of the group (or an object attached to
        one) in collision? ``verbose`` logs the contacts."""
        args = list(args)
        if args and not isinstance(args[0], str):
            robot_state = args.pop(0)
        if args:
            joint_model_group_name = args.pop(0)
        if args:
            verbose = bool(args.pop(0))
        contacts = self._group_contacts(robot_state, joint_model_group_name)
        if verbose:
            for contact in contacts:
                _LOG.info(f"Collision: {contact}")
            if not contacts:
                _LOG.info(f"No collision for group '{joint_model_group_name}'")
        return bool(contacts)

    def is_state_valid(self, robot_state: Any, joint_model_group_name: str, verbose: bool = False) -> bool:
        """Inside the joint limits and not colliding."""
        state = self._state(robot_state)
        inside = state.satisfies_bounds()
        if verbose and not inside:
            _LOG.info("State outside the joint limits: " + "; ".join(state.violated_bounds()))
        return inside and not self.is_state_colliding(state, joint_model_group_name, verbose)

    def is_state_constrained(self, state: Any, constraints: Any, verbose: bool = False) -> bool:
        """Does the state satisfy the moveit_msgs/Constraints (joint, position, orientation)?"""
        satisfied, why = constraints_satisfied(self._scene, self._state(state), constraints)
        if verbose and not satisfied:
            _LOG.info(f"Constraints not satisfied: {why}")
        return satisfied

    def is_path_valid(self, trajectory: Any, joint_model_group_name: str, verbose: bool = False,
                      invalid_index: Any = None) -> bool:
        """Every state along the trajectory valid (the trajectory validator's dense check)."""
        timed = trajectory.timed_trajectory
        report = validate_trajectory(self._scene, timed, joint_model_group_name or trajectory.joint_model_group_name,
                                     None, check_limits=False)
        if verbose and not report.valid:
            _LOG.info("Path invalid: " + "; ".join(report.problems[:3]))
        return report.valid

    def knows_frame_transform(self, *args: Any) -> bool:
        """``(frame_id)`` or ``(robot_state, frame_id)``: a link, an object or an attached object?"""
        frame_id = args[-1]
        try:
            self._scene.frame_pose(frame_id, core_state(args[0]) if len(args) > 1 else None)
            return True
        except (PlanningError, ValueError, KeyError):
            return False

    def get_frame_transform(self, frame_id: str) -> np.ndarray:
        """The frame's pose in the planning frame; identity when the scene does not know it."""
        try:
            return self._scene.frame_pose(frame_id)
        except (PlanningError, ValueError, KeyError):
            return np.eye(4)

    def __copy__(self) -> "PlanningScene":
        return PlanningScene._wrap(self._scene.copy())

    def __deepcopy__(self, memo: dict) -> "PlanningScene":
        return self.__copy__()

    def __repr__(self) -> str:
        return f"PlanningScene(robot={self._scene.robot_model.name!r}, objects={self._scene.world_object_ids()})"


def core_scene(scene: Any) -> Any:
    """The core PlanningScene of a moveit_py PlanningScene (anything else: unchanged)."""
    return scene._scene if isinstance(scene, PlanningScene) else scene
