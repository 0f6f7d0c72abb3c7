"""SimpleGrasp and SimpleUnGrasp: the end effector's part of a pick or a place, as one container
(MTC's stages::SimpleGrasp / SimpleUnGrasp).

Why a container: grasping is always the same four steps around a grasp (or place) pose
generator, and they must agree on the end effector and the object. The container builds them
and feeds them ``eef`` and ``object`` (set on it, or inherited from a Pick / Place), so a task
only supplies the generator:

* SimpleGrasp: ``compute ik`` (ComputeIK wrapping the generator) → ``allow object collision``
  (object vs the end effector's links) → ``close gripper`` (MoveTo the ``grasp`` posture) →
  ``attach object`` (to the end effector's parent link).
* SimpleUnGrasp: ``compute ik`` → ``detach object`` → ``open gripper`` (MoveTo the ``pregrasp``
  posture) → ``forbid object collision`` (MTC's order: its constructor inserts each step right
  after the IK, so they end up reversed).

The postures come from the interface (GenerateGraspPose puts ``pregrasp`` / ``grasp`` in its
states, and every step forwards them), unless set on the container, which then wins.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np

from ...core.planning_scene.planning_scene import PlanningScene
from ...core.robot_model.robot_model import RobotModel
from ..errors import InitStageException, TaskError
from ..geometry import PoseStamped, as_pose_stamped
from ..properties import PropertyMap, PropertySetter
from ..solvers import JointInterpolationPlanner
from ..containers import SerialContainer
from ..stage import Stage
from ..storage import BACKWARD, InterfaceState
from .compute_ik import ComputeIK
from .modify_planning_scene import ModifyPlanningScene
from .move_to import MoveTo

__all__ = ["GRASP_PROPERTIES", "SimpleGrasp", "SimpleGraspBase", "SimpleUnGrasp"]

#: What the grasp generator hands on through the interface, forwarded along every step so the
#: place side (GeneratePlacePose monitoring the pick) still knows the postures.
GRASP_PROPERTIES = frozenset({"object", "eef", "pregrasp", "grasp"})

_PARENT_OR_INTERFACE = Stage.PARENT | Stage.INTERFACE


def read_property(source: PropertyMap | Mapping[str, Any], name: str) -> Any:
    """A defined value from a stage's properties or an interface state's; LookupError (which
    ``performInitFrom`` skips) when it is not declared there or undefined."""
    if isinstance(source, PropertyMap):
        value = source.property(name).value()  # PropertyUndeclared is a LookupError
    else:
        value = source[name]
    if value is None:
        raise LookupError(name)
    return value


def eef_collision_links(model: RobotModel, eef: str) -> list[str]:
    """The end effector's links that have collision geometry (what may touch the object)."""
    with_geometry = set(model.links_with_collision_geometry())
    return [link for link in model.group(model.end_effectors[eef].group).link_names if link in with_geometry]


class _ObjectSceneChange(ModifyPlanningScene):
    """A scene change about ``object`` and ``eef`` read when the state arrives (from the parent
    or the interface). ``change(scene, eef, object, forward)`` applies it; propagating backward
    applies the inverse, as ModifyPlanningScene does with its own changes (MTC's callback is
    applied unchanged either way, which only matters without a generator)."""

    def __init__(self, name: str, change: Callable[[PlanningScene, str, str, bool], None], forward: bool) -> None:
        super().__init__(name)
        p = self._properties
        p.declare("eef", type=str, description="end effector whose links / parent link are used")
        p.declare("object", type=str, description="object to attach, detach or allow collisions with")
        p.configureInitFrom(_PARENT_OR_INTERFACE, ["eef", "object"])
        self._change = change
        self._forward = forward
        self._along = True  # direction of the state being propagated
        self.setForwardedProperties(GRASP_PROPERTIES)
        self.setCallback(self._apply)

    def _propagate(self, state: InterfaceState, direction: int):
        self._along = direction != BACKWARD
        return super()._propagate(state, direction)

    def _apply(self, scene: PlanningScene, properties: PropertyMap) -> None:
        eef, name = properties["eef"], properties["object"]
        if eef is None or name is None:
            raise TaskError(f"property '{'eef' if eef is None else 'object'}' is undefined")
        if eef not in scene.robot_model.end_effectors:
            raise TaskError(f"unknown end effector '{eef}'")
        self._change(scene, eef, name, self._forward == self._along)


# Introspection (TaskDescription's stage type, repr) names it as MTC does: a ModifyPlanningScene.
_ObjectSceneChange.__name__ = _ObjectSceneChange.__qualname__ = "ModifyPlanningScene"


def _allow_touch(scene: PlanningScene, eef: str, name: str, allow: bool) -> None:
    if not scene.has_object(name):
        raise TaskError(f"object '{name}' is not in the scene")
    scene.allow_collisions([name], eef_collision_links(scene.robot_model, eef), allow)


def _attach(scene: PlanningScene, eef: str, name: str, attach: bool) -> None:
    link = scene.robot_model.end_effectors[eef].parent_link
    if attach:
        scene.attach_object(name, link)
        return
    if scene.is_attached(name):
        attached_to = scene.get_attached_object(name).link_name
        if attached_to != link:
            raise TaskError(f"cannot detach '{name}' from '{link}': it is attached to '{attached_to}'")
    scene.detach_object(name)  # SceneError (named) when it is not attached


class SimpleGraspBase(SerialContainer):
    """The common part of SimpleGrasp (forward) and SimpleUnGrasp (reverse)."""

    def __init__(self, generator: Stage | None, name: str, forward: bool) -> None:
        super().__init__(name)
        if generator is not None and not isinstance(generator, Stage):
            raise TaskError(f"{type(self).__name__} '{name}': the pose generator must be a Stage, "
                            f"got {type(generator).__name__}")
        self._model: RobotModel | None = None
        p = self._properties
        p.declare("eef", type=str, description="end-effector to grasp with")
        p.declare("object", type=str, description="object to grasp (must be in the planning scene)")
        p.declare("pregrasp", description="pre-grasp posture (named state or joint map); default: the generator's")
        p.declare("grasp", description="grasp posture (named state or joint map); default: the generator's")
        self.setForwardedProperties(GRASP_PROPERTIES)
        self._ik: ComputeIK | None = None
        self._setup(generator, forward)

    def _setup(self, generator: Stage | None, forward: bool) -> None:
        if generator is not None:
            if generator.parent is not None:
                raise TaskError(f"stage '{generator.name}' already belongs to container '{generator.parent.name}'")
            generator.setForwardedProperties(GRASP_PROPERTIES)
            generator.properties.configureInitFrom(Stage.PARENT, ["object", "eef"])
            ik = ComputeIK("compute ik", generator)
            ik.setForwardedProperties(GRASP_PROPERTIES)
            p = ik.properties
            p.declare("object", type=str, description="object to grasp")
            p.configureInitFrom(Stage.INTERFACE, ["target_pose"])
            p.configureInitFrom(Stage.PARENT, ["max_ik_solutions", "timeout", "object"])
            p.configureInitFrom(_PARENT_OR_INTERFACE, ["eef", "ik_frame"])
            p.exposeTo(self._properties, ["max_ik_solutions", "timeout", "ik_frame"])
            self._ik = ik
        else:
            # Without a generator (MTC allows it) nothing reads these; declared so the API stays.
            self._properties.declare("max_ik_solutions", 1, "maximum number of IK solutions per target", type=int)
            self._properties.declare("ik_frame", type=PoseStamped, coerce=as_pose_stamped,
                                     description="frame to be moved towards the goal pose")
        touch = _ObjectSceneChange("allow object collision" if forward else "forbid object collision",
                                   _allow_touch, forward)
        move = MoveTo("close gripper" if forward else "open gripper", JointInterpolationPlanner())
        move.setForwardedProperties(GRASP_PROPERTIES)
        p = move.properties
        p.property("group").configureInitFrom(_PARENT_OR_INTERFACE, self._eef_group)
        p.property("goal").configureInitFrom(_PARENT_OR_INTERFACE, "grasp" if forward else "pregrasp")
        attach = _ObjectSceneChange("attach object" if forward else "detach object", _attach, forward)
        steps = [touch, move, attach] if forward else [attach, move, touch]
        for step in ([self._ik] if self._ik is not None else []) + steps:
            self.insert(step)

    def _eef_group(self, source: PropertyMap | Mapping[str, Any]) -> str:
        """The end effector's group, for the gripper MoveTo (needs the model: known at init)."""
        eef = read_property(source, "eef")
        model = self._model
        if model is None or eef not in model.end_effectors:
            raise LookupError(eef)  # reported by init() as an unknown end effector
        return model.end_effectors[eef].group

    # ------------------------------------------------------------------ MTC's setters
    setEndEffector = PropertySetter("eef", str)
    setObject = PropertySetter("object", str)

    def setIKFrame(self, pose_or_link: Any, link: str | None = None) -> None:
        """The frame placed at the generated poses: a PoseStamped, a (pose, link) offset from a
        link, or a link."""
        if link is None:
            self._properties.set("ik_frame", pose_or_link)
        else:
            if not isinstance(link, str):
                raise TaskError(f"stage '{self._name}': setIKFrame(pose, link) needs a link name, got {link!r}")
            try:
                frame = PoseStamped(link, np.asarray(pose_or_link, dtype=float))
            except (TypeError, ValueError) as exc:
                raise TaskError(f"stage '{self._name}': setIKFrame: {exc}") from None
            self._properties.set("ik_frame", frame)

    setMaxIKSolutions = PropertySetter("max_ik_solutions", int)

    # ------------------------------------------------------------------ life cycle
    def init(self, robot_model: RobotModel) -> None:
        self._model = robot_model
        errors = InitStageException().collect(Stage.init, self, robot_model)
        p = self._properties
        eef = p["eef"]
        if eef is None:
            if "eef" not in getattr(self, "_bad_properties", ()):
                errors.push_back(self, "property 'eef' is undefined: set the end effector (setEndEffector) here or "
                                       "on the enclosing Pick / Place")
        else:
            self._check_eef(eef, robot_model, errors)
        if p["object"] is None and "object" not in getattr(self, "_bad_properties", ()):
            errors.push_back(self, "property 'object' is undefined: set the object (setObject) here or on the "
                                   "enclosing Pick / Place")
        for child in self._children:
            errors.collect(child.init, robot_model)
        if errors:
            raise errors


class SimpleGrasp(SimpleGraspBase):
    """IK for the generated grasp poses, then close the gripper on the object and attach it."""

    def __init__(self, pose_generator: Stage | None = None, name: str = "grasp") -> None:
        super().__init__(pose_generator, name, True)


class SimpleUnGrasp(SimpleGraspBase):
    """IK for the generated place poses, then detach the object and open the gripper."""

    def __init__(self, pose_generator: Stage | None = None, name: str = "ungrasp") -> None:
        super().__init__(pose_generator, name, False)
