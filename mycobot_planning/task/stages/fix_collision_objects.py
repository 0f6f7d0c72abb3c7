"""FixCollisionObjects: push world objects the robot slightly penetrates out of it (MTC's
stages::FixCollisionObjects).

Why: perceived objects (or a scene built by hand) often overlap the robot by a few
millimetres, and then every state of the task is in collision. This stage passes the state on
with each such object moved out of the robot, or fails, saying which contact it could not fix.

For every contact between the robot (links and attached objects, under the allowed collision
matrix) and a world object, the object is moved along the contact normal, away from the robot,
by the penetration depth plus 1 mm; then the scene is checked again, until it is free. A
correction longer than ``max_penetration`` fails the state, and so does a contact between robot
bodies only (nothing to move). With ``direction`` set, each correction moves the object by that
vector (in the planning frame) instead, as in MTC; the depth check still applies.

Contact depths and normals come from the scene's collision checker (Coal): the normal is the
direction between the deepest points of the two bodies. For a robot link given as a mesh, Coal
measures the depth to the mesh's surface triangles, not through the volume (as MoveIt's FCL
does), so a deep overlap may read as shallow and need several rounds, or none may resolve it.
Hence one rule MTC does not have: without ``direction``, the corrections of one object may add
up to ``max_penetration`` at most, so an object is never pushed further than that in total.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ...core.collision_detection.collision_common import OBJECT, SECURITY_MARGIN
from ...core.planning_scene.planning_scene import PlanningScene
from ..cost_terms import Constant
from ..errors import InitStageException
from ..properties import PropertySetter
from ..stage import PropagatingEitherWay
from ..storage import InterfaceState, SubTrajectory

__all__ = ["FixCollisionObjects"]

#: Added to every correction (m) so the object ends clear of the robot, not touching it (MTC's).
CLEARANCE = 1e-3
#: Rounds of check-and-correct before giving up (each moves every penetrating object >= 1 mm).
MAX_ROUNDS = 100


def _as_vector(value: Any) -> np.ndarray:
    if hasattr(value, "x") and hasattr(value, "y") and hasattr(value, "z"):  # geometry_msgs/Vector3
        value = (value.x, value.y, value.z)
    vector = np.array(value, dtype=float).reshape(-1)
    if vector.size != 3 or not np.all(np.isfinite(vector)):
        raise ValueError("direction needs 3 finite numbers (x, y, z)")
    if np.linalg.norm(vector) == 0.0:
        raise ValueError("direction must not be the zero vector")
    return vector


class _Unfixable(Exception):
    """A contact this stage cannot resolve; the message becomes the failure's comment."""


class FixCollisionObjects(PropagatingEitherWay):
    def __init__(self, name: str = "fix collisions") -> None:
        super().__init__(name)
        self.setCostTerm(Constant(0.0))
        p = self._properties
        p.declare("max_penetration", type=float, description="maximally corrected penetration depth (m)")
        p.declare("direction", type=np.ndarray, coerce=_as_vector,
                  description="direction vector to use for corrections (planning frame; default: contact normal)")

    setMaxPenetration = PropertySetter("max_penetration", float)
    setDirection = PropertySetter("direction", Any)

    def init(self, robot_model) -> None:
        errors = InitStageException().collect(super().init, robot_model)
        value = self._require_property("max_penetration", errors)
        if value is not None and value < 0.0:
            errors.push_back(self, f"property 'max_penetration' must be >= 0, got {value:g}")
        if errors:
            raise errors

    def _propagate(self, state: InterfaceState, direction: int):
        scene = state.scene.diff()
        solution = SubTrajectory()
        max_penetration = self._properties["max_penetration"]
        if max_penetration is None:
            solution.markAsFailure("property 'max_penetration' is undefined")
            return False, scene, solution
        try:
            moved = self._fix(scene, float(max_penetration))
        except _Unfixable as exc:
            solution.markAsFailure(str(exc))
            return False, scene, solution
        if moved:
            solution.comment = "moved " + ", ".join(f"'{name}' by {1000 * distance:.1f} mm"
                                                    for name, distance in moved.items())
        return True, scene, solution

    def _fix(self, scene: PlanningScene, max_penetration: float) -> dict[str, float]:
        """Move world objects out of the robot in ``scene``; how far each moved (m) in total."""
        moved: dict[str, float] = {}
        corrected: dict[str, float] = {}  # sum of the corrections computed per object
        fixed_direction = self._properties["direction"]
        for _ in range(MAX_ROUNDS):
            report = scene.check_collision()
            if not report.collision:
                return moved
            for contact in report.contacts:
                if contact.kind_a != OBJECT and contact.kind_b != OBJECT:
                    raise _Unfixable(f"cannot fix collision between '{contact.body_a}' and '{contact.body_b}': "
                                     f"no world object to move")
                name, robot_body = (contact.body_a, contact.body_b) if contact.kind_a == OBJECT \
                    else (contact.body_b, contact.body_a)
                found = self._correction(scene, name, robot_body, contact.position)
                if found is None:
                    continue  # resolved by an earlier correction this round
                name, correction = found
                length = float(np.linalg.norm(correction))
                if length > max_penetration:
                    raise _Unfixable(f"'{name}' penetrates '{robot_body}' too deeply: the correction of "
                                     f"{1000 * length:.1f} mm exceeds max_penetration ({1000 * max_penetration:.1f} mm)")
                if fixed_direction is not None:
                    correction = np.asarray(fixed_direction, dtype=float)
                else:
                    corrected[name] = corrected.get(name, 0.0) + length
                    if corrected[name] > max_penetration:
                        raise _Unfixable(f"'{name}' penetrates '{robot_body}' too deeply: corrections add up to "
                                         f"{1000 * corrected[name]:.1f} mm, more than max_penetration "
                                         f"({1000 * max_penetration:.1f} mm)")
                pose = scene.frame_pose(name).copy()
                pose[:3, 3] += correction
                scene.move_object(name, pose)
                moved[name] = moved.get(name, 0.0) + float(np.linalg.norm(correction))
        if scene.check_collision().collision:
            raise _Unfixable(f"still in collision after {MAX_ROUNDS} rounds of corrections: {scene.check_collision()}")
        return moved

    @staticmethod
    def _correction(scene: PlanningScene, name: str, robot_body: str,
                    position: tuple[float, float, float] | None) -> tuple[str, np.ndarray] | None:
        """The world object to move for this contact and by how much: away from ``robot_body``
        along the line between the two bodies' deepest points, by the depth + CLEARANCE. The
        deepest pair of ``robot_body`` with any world object is taken (usually ``name``; another
        object when that one is deeper, which is corrected first then). None when the pair no
        longer collides."""
        report = scene.distance(include_self=False, include_world=True, links=[robot_body])
        if report.body_a is None:  # (every pair of robot_body allowed meanwhile)
            return None
        if report.kind_a == OBJECT:
            obj, on_object, on_robot = report.body_a, report.point_a, report.point_b
        else:
            obj, on_object, on_robot = report.body_b, report.point_b, report.point_a
        if report.min_distance > SECURITY_MARGIN:
            return None
        depth = max(0.0, -float(report.min_distance))
        normal = np.zeros(3)
        if on_object is not None and on_robot is not None:
            # Penetrating: the object's deepest point lies inside the robot body, the body's
            # inside the object; moving the object by (robot point - object point) separates them.
            normal = np.subtract(on_robot, on_object) * (1.0 if report.min_distance < 0.0 else -1.0)
        if np.linalg.norm(normal) < 1e-9:
            # Touching (no depth to measure): push the object away from the contact point.
            if position is None or obj != name:
                raise _Unfixable(f"cannot determine the contact normal between '{obj}' and '{robot_body}'")
            normal = scene.frame_pose(obj)[:3, 3] - np.asarray(position, dtype=float)
            if np.linalg.norm(normal) < 1e-9:
                raise _Unfixable(f"cannot determine the contact normal between '{obj}' and '{robot_body}'")
        normal = normal / np.linalg.norm(normal)
        return obj, (depth + CLEARANCE) * normal
