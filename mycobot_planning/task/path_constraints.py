"""MTC's ``path_constraints`` property (MoveTo, MoveRelative, Connect): a moveit_msgs/Constraints
every state of the stage's trajectory must satisfy, handed to the stage's planner.

The property takes what MTC's users write, ``stage.path_constraints = constraints`` with a
moveit_msgs/Constraints built field by field (read here by its field names only: this package
never imports ROS), the same message in dict form (its field names), the core's JSON form
(``{"joints": [...], "orientation": [...], "position": [...]}``, see
core/kinematic_constraints/kinematic_constraints.py), or an already resolved core ``PathConstraints``. It is kept as a
:class:`PathConstraintsSpec`; the planners resolve it in the scene they plan from (frames at the
start state; a constraint's ``link_name`` may be a robot link or a collision object attached in
that scene, as in MTC's constrained.py and pickplace.py demos).
"""
from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ..core.kinematic_constraints.kinematic_constraints import (
    ConstraintError,
    PathConstraints,
    attached_frames,
    constraints_json_from_msg,
    path_constraints_from_json,
)
from ..core.robot_state.robot_state import RobotState

if TYPE_CHECKING:  # pragma: no cover
    from ..core.planning_scene.planning_scene import PlanningScene
    from ..core.robot_model.robot_model import RobotModel

_JSON_KEYS = {"joints", "orientation", "position"}
_MESSAGE_KEYS = {"name", "joint_constraints", "position_constraints", "orientation_constraints",
                 "visibility_constraints"}


class PathConstraintsSpec:
    """Path constraints as given to a stage: the JSON form (resolved per planning scene) or a
    core PathConstraints (used as it is). Falsy when it constrains nothing."""

    __slots__ = ("data", "resolved", "name")

    def __init__(self, data: Mapping[str, Any] | None = None, resolved: PathConstraints | None = None,
                 name: str = "") -> None:
        self.data = {kind: list(data.get(kind, [])) for kind in ("joints", "orientation", "position")} \
            if data else None
        self.resolved = resolved if resolved else None
        self.name = name

    def __bool__(self) -> bool:
        return bool(self.data) or bool(self.resolved)

    def __repr__(self) -> str:
        if self.resolved is not None:
            return f"PathConstraints({self.resolved.describe()})"
        return f"PathConstraints({self.name + ': ' if self.name else ''}{self.key()})"

    def key(self) -> str:
        """Identifies the constraints (plan caches key on it)."""
        if self.resolved is not None:
            return f"resolved:{id(self.resolved)}"
        return json.dumps(self.data, sort_keys=True)

    def targets(self) -> list[str]:
        """The links (or attached objects) the orientation and position constraints name."""
        if self.resolved is not None:
            return [c.label for c in (*self.resolved.orientations, *self.resolved.positions)]
        if not self.data:
            return []
        return [str(entry.get("link")) for kind in ("orientation", "position") for entry in self.data.get(kind, [])]

    def problems(self, robot_model: "RobotModel", object_ids: set[str] | None = None) -> list[str]:
        """What is wrong with these constraints for ``robot_model`` (empty: nothing). A link name
        that is no robot link must be a collision object the task knows (``object_ids``; None:
        not known before planning, then it is checked in the planning scene)."""
        if self.resolved is not None:
            bad = [link for link in self.resolved.links if not robot_model.has_link(link)]
            return [f"links {bad} are not links of robot '{robot_model.name}'"] if bad else []
        if not self.data:
            return []
        problems = []
        objects = {name for name in self.targets() if not robot_model.has_link(name)}
        if object_ids is not None:
            for name in sorted(objects - object_ids):
                known = f" (known objects: {', '.join(sorted(object_ids))})" if object_ids else ""
                problems.append(f"unknown link '{name}': neither a link of robot '{robot_model.name}' nor a "
                                f"collision object of the task{known}")
        # everything else: parse against the model, objects standing in as attached to the root
        stand_in = {name: (robot_model.root_link, np.eye(4)) for name in objects}
        try:
            path_constraints_from_json(self.data, RobotState(robot_model), lambda frame: np.eye(4), stand_in)
        except (ConstraintError, KeyError, TypeError, ValueError) as exc:
            problems.append(str(exc))
        return problems

    def resolve(self, scene: "PlanningScene") -> PathConstraints | None:
        """The core constraints in ``scene`` (frames and attached objects at its current state);
        None when there are none. ConstraintError names what cannot be resolved."""
        if self.resolved is not None:
            return self.resolved
        if not self.data:
            return None
        state = scene.current_state

        def frame_pose(frame: str) -> np.ndarray:
            try:
                return scene.frame_pose(frame, state)
            except (ValueError, KeyError) as exc:
                raise ConstraintError(f"constraint frame: {exc}") from None

        constraints = path_constraints_from_json(self.data, state, frame_pose, attached_frames(scene, state),
                                                 self.name)
        return constraints or None


def _looks_like_message(value: Any) -> bool:
    return all(hasattr(value, name) for name in ("joint_constraints", "position_constraints",
                                                   "orientation_constraints"))


def as_path_constraints(value: Any) -> PathConstraintsSpec:
    """The property's coercion: a moveit_msgs/Constraints (duck-typed), its dict form, the core's
    JSON form, or a core PathConstraints (TypeError/ValueError otherwise, naming the problem)."""
    if isinstance(value, PathConstraintsSpec):
        return value
    if isinstance(value, PathConstraints):
        return PathConstraintsSpec(resolved=value, name=value.name)
    try:
        if isinstance(value, Mapping):
            keys = set(value)
            if keys and keys <= _JSON_KEYS:
                for kind in keys:
                    entries = value[kind]
                    if not isinstance(entries, (list, tuple)) or not all(isinstance(e, Mapping) for e in entries):
                        raise ValueError(f"'{kind}' must be a list of objects")
                return PathConstraintsSpec(data={k: [dict(e) for e in value[k]] for k in keys})
            if keys <= _MESSAGE_KEYS:
                return PathConstraintsSpec(constraints_json_from_msg(value), name=str(value.get("name", "") or ""))
            raise ValueError(f"a dict of path constraints has the keys of moveit_msgs/Constraints "
                             f"({', '.join(sorted(_MESSAGE_KEYS))}) or of the JSON form "
                             f"({', '.join(sorted(_JSON_KEYS))}); got {sorted(keys)}")
        if _looks_like_message(value):
            return PathConstraintsSpec(constraints_json_from_msg(value), name=str(getattr(value, "name", "") or ""))
    except ConstraintError as exc:
        raise ValueError(str(exc)) from None
    raise TypeError("expected a moveit_msgs/Constraints, its dict form, the JSON form "
                    "{'joints', 'orientation', 'position'} or a core PathConstraints")


def declare_path_constraints(properties: Any) -> None:
    """Declare MTC's ``path_constraints`` property (default: none)."""
    properties.declare("path_constraints", None, "constraints to maintain during trajectory",
                       type=PathConstraintsSpec, coerce=as_path_constraints)


def task_object_ids(stage: Any) -> set[str] | None:
    """The collision object ids a stage's task may hold when it plans: those of the task's scene,
    and those its stages add, attach, start from or name as their ``object``. None when the
    task's scene is only known when planning starts (a scene provider, e.g. move_group's
    monitored scene): names are then checked in it."""
    context = getattr(stage, "_context", None)
    task = getattr(context, "task", None)
    if context is None or task is None or getattr(task, "_scene_provider", None) is not None:
        return None
    scene = getattr(task, "_scene", None)
    ids = set(scene.world_object_ids()) | set(scene.attached_object_ids()) if scene is not None else set()
    for other, _depth in context.root.traverseRecursively():
        for obj in getattr(other, "_objects", ()) or ():  # ModifyPlanningScene.addObject
            if isinstance(getattr(obj, "id", None), str):
                ids.add(obj.id)
        for entry in getattr(other, "_attach", ()) or ():  # ModifyPlanningScene.attachObjects
            names = entry[1] if isinstance(entry, tuple) and len(entry) > 1 else ()
            ids.update(n for n in names if isinstance(n, str))
        fixed = getattr(other, "_scene", None)  # CurrentState / FixedState with a scene of their own
        if fixed is not None and hasattr(fixed, "world_object_ids"):
            ids.update(fixed.world_object_ids())
            ids.update(fixed.attached_object_ids())
        properties = getattr(other, "properties", None)
        if properties is not None and "object" in properties:
            value = properties.get("object")
            if isinstance(value, str) and value:
                ids.add(value)
    return ids


def check_path_constraints(stage: Any, robot_model: "RobotModel", errors: Any) -> None:
    """Report the stage's path_constraints problems into ``errors`` (an InitStageException)."""
    spec = stage.properties.get("path_constraints")
    if not spec:
        return
    for problem in spec.problems(robot_model, task_object_ids(stage)):
        errors.push_back(stage, f"property 'path_constraints': {problem}")
