"""ModifyPlanningScene: change the scene without moving the robot (MTC's
stages::ModifyPlanningScene): attach / detach objects, allow / forbid collisions, add / remove
objects, or run a callback on the scene.

Works in both directions: propagating backward applies the inverse change (attach becomes
detach, allow becomes forbid, add becomes remove), so a pick container can be planned from the
grasp backward and forward alike. The resulting state is checked for collisions; touching
contacts (penetration below ``RESTING_CONTACT_DEPTH``) are not counted, so attaching an object
that stands on its support succeeds, as it does with MoveIt (the following "allow collision
(object, support)" stage then makes the contact explicit).
"""
from __future__ import annotations

from typing import Any, Callable, Iterable, Mapping

from interfaces_py.msgs import CollisionObject, MessageError
from interfaces_py.ros_message_reading import ConversionError, collision_object_from_msg

from ...core.errors import PlanningError
from ...core.robot_model.robot_model import JointModelGroup
from ..cost_terms import Constant
from ..errors import TaskError
from ..stage import PropagatingEitherWay
from ..storage import BACKWARD, InterfaceState, SubTrajectory

#: Contacts shallower than this (m) are resting contacts, not collisions, for the state check.
RESTING_CONTACT_DEPTH = 1e-5

Names = str | Iterable[str] | JointModelGroup


def _names(value: Names, what: str) -> list[str]:
    if isinstance(value, JointModelGroup):
        return list(value.link_names)
    if isinstance(value, str):
        return [value]
    try:
        names = list(value)
    except TypeError:
        raise TaskError(f"{what}: expected a name, a list of names or a JointModelGroup, got {type(value).__name__}") from None
    for name in names:
        if not isinstance(name, str) or not name:
            raise TaskError(f"{what}: invalid name {name!r}")
    return names


class ModifyPlanningScene(PropagatingEitherWay):
    def __init__(self, name: str = "modify planning scene") -> None:
        super().__init__(name)
        self.setCostTerm(Constant(0.0))
        self._attach: list[tuple[str, list[str], bool]] = []  # (link, objects, attach?)
        self._acm_edits: list[tuple[list[str], list[str] | None, bool]] = []
        self._objects: list[CollisionObject] = []
        self._callback: Callable[[Any, Any], None] | None = None

    # ------------------------------------------------------------------ configuration (MTC's API)
    def attachObject(self, name: str, link: str) -> None:
        self.attachObjects([name], link, True)

    def detachObject(self, name: str, link: str) -> None:
        self.attachObjects([name], link, False)

    def attachObjects(self, names: Names, link: str, attach: bool = True) -> None:
        if not isinstance(link, str) or not link:
            raise TaskError(f"stage '{self._name}': attach link must be a link name, got {link!r}")
        self._attach.append((link, _names(names, f"stage '{self._name}'"), bool(attach)))

    def detachObjects(self, names: Names, link: str) -> None:
        self.attachObjects(names, link, False)

    def allowCollisions(self, first: Names, second: Names | None = None, allow: bool = True) -> None:
        """Allow (or forbid, allow=False) collisions between the two sets of bodies (links,
        objects, group names); without ``second``, between ``first`` and everything."""
        if isinstance(second, bool):  # allowCollisions(first, True)
            second, allow = None, second
        self._acm_edits.append((_names(first, f"stage '{self._name}'"),
                                None if second is None else _names(second, f"stage '{self._name}'"), bool(allow)))

    def forbidCollisions(self, first: Names, second: Names | None = None) -> None:
        self.allowCollisions(first, second, False)

    def addObject(self, obj: Any) -> None:
        """Add a collision object: a moveit_msgs/CollisionObject (as MTC's scripts build them,
        field by field), its dict form, or an interfaces_py CollisionObject; operation ADD."""
        try:
            if isinstance(obj, Mapping):
                obj = CollisionObject.from_dict(obj)
            elif not isinstance(obj, CollisionObject) and hasattr(obj, "header") and hasattr(obj, "primitives"):
                obj = CollisionObject.from_dict(collision_object_from_msg(obj))
        except (MessageError, ConversionError) as exc:
            raise TaskError(f"stage '{self._name}': addObject: {exc}") from None
        if not isinstance(obj, CollisionObject) or obj.operation != CollisionObject.ADD:
            raise TaskError(f"stage '{self._name}': addObject needs a CollisionObject with operation ADD")
        self._objects.append(obj)

    def removeObject(self, name: str) -> None:
        self._objects.append(CollisionObject(id=name, frame_id="world", operation=CollisionObject.REMOVE))

    def setCallback(self, callback: Callable[[Any, Any], None] | None) -> None:
        """Call ``callback(scene, properties)`` on the new scene (after the other changes)."""
        self._callback = callback

    # ------------------------------------------------------------------ planning
    def init(self, robot_model) -> None:
        super().init(robot_model)

    def _propagate(self, state: InterfaceState, direction: int):

        invert = direction == BACKWARD
        scene = state.scene.diff()
        solution = SubTrajectory()
        try:
            for obj in self._objects:
                if invert:
                    if obj.operation == CollisionObject.REMOVE:
                        raise TaskError("cannot apply removeObject() backwards")
                    scene.remove_object(obj.id)
                else:
                    scene.apply_collision_object(obj)
            for link, names, attach in self._attach:
                for name in names:
                    if attach != invert:
                        scene.attach_object(name, link)
                    else:
                        if scene.is_attached(name) and scene.get_attached_object(name).link_name != link:
                            raise TaskError(f"cannot detach '{name}' from '{link}': it is attached to "
                                            f"'{scene.get_attached_object(name).link_name}'")
                        scene.detach_object(name)
            for first, second, allow in self._acm_edits:
                scene.allow_collisions(first, second, allow != invert)
            if self._callback is not None:
                self._callback(scene, self._properties)
            report = scene.check_collision(max_contacts=5)
            contacts = [c for c in report.contacts if c.depth > RESTING_CONTACT_DEPTH]
            if report.collision and (contacts or not report.contacts):
                contact = contacts[0] if contacts else None
                solution.markAsFailure(f"{contact.body_a} colliding with {contact.body_b}" if contact else "in collision")
        except (PlanningError, ValueError, KeyError) as exc:
            solution.markAsFailure(str(exc))
        return not solution.is_failure, scene, solution
