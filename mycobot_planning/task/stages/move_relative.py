"""MoveRelative: move the ik frame along a direction or twist, or the joints by offsets (MTC's
stages::MoveRelative).

``direction`` is a Vector3Stamped (translation in a frame's axes), a TwistStamped (translation
plus rotation about the ik frame's origin, in a frame's axes) or a joint map of offsets.
``max_distance`` > 0 scales the motion to that length (m, or rad for a pure rotation);
``min_distance`` decides success as in MTC: > 0, at least that far; 0, any distance; < 0
(default -1), the full motion. When min and max are equal the full motion is required.
Backward propagation plans from the end state along the inverted motion and reverses the
trajectory. Cost: joint-space path length. ``path_constraints`` (a moveit_msgs/Constraints, see
task/path_constraints.py) go to the planner.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from ...core.transforms import inverse
from ..errors import InitStageException
from ..geometry import TwistStamped, Vector3Stamped, as_twist_stamped, as_vector3_stamped, frame_transform
from ..properties import PropertySetter
from ..solvers import PlannerInterface
from ..storage import BACKWARD, InterfaceState, SubTrajectory
from .planning_stage import PlanningStage
from .common import first_conversion, robot_tip_for_frame

_EPS = np.finfo(float).eps


def _as_direction(value: Any) -> Any:
    if isinstance(value, (Vector3Stamped, TwistStamped)):
        return value
    if isinstance(value, dict):
        out = {}
        for name, offset in value.items():
            if not isinstance(name, str) or isinstance(offset, bool) or not isinstance(offset, (int, float)):
                raise ValueError("a joint-offset direction maps joint names to numbers")
            out[name] = float(offset)
        return out
    return first_conversion(value, (as_twist_stamped, as_vector3_stamped),
                            "expected a Vector3Stamped, a TwistStamped or a joint map of offsets")


class MoveRelative(PlanningStage):
    _motion = "direction"

    def __init__(self, name: str = "move relative", planner: PlannerInterface | None = None) -> None:
        super().__init__(name, planner, "frame to be moved in Cartesian direction")
        p = self._properties
        p.declare("direction", description="motion specification", coerce=_as_direction)
        p.declare("min_distance", -1.0, "minimum distance to move", type=float)
        p.declare("max_distance", 0.0, "maximum distance to move", type=float)
        self._declare_path_constraints()

    setDirection = PropertySetter("direction", Any)
    setMinDistance = PropertySetter("min_distance", float)
    setMaxDistance = PropertySetter("max_distance", float)

    def setMinMaxDistance(self, min_distance: float, max_distance: float) -> None:
        self.setMinDistance(min_distance)
        self.setMaxDistance(max_distance)

    def _check_motion(self, robot_model: Any, group: Any, direction: Any, errors: InitStageException) -> None:
        if self._check_group("group", group, robot_model, errors) and isinstance(direction, dict):
            joints = robot_model.group(group).joint_names
            unknown = [name for name in direction if name not in joints]
            if unknown:
                errors.push_back(self, f"property 'direction': joints {unknown} are not part of group '{group}'")
        p = self._properties
        if p["max_distance"] is not None and p["min_distance"] is not None and p["max_distance"] > 0 \
                and p["min_distance"] > p["max_distance"]:
            errors.push_back(self, f"property 'min_distance' ({p['min_distance']:g}) exceeds 'max_distance' "
                                   f"({p['max_distance']:g}): the motion can never succeed")

    def _propagate(self, state: InterfaceState, direction: int):
        scene, failure = self._start_propagation(state)
        if failure is not None:
            return False, scene, failure
        model = scene.robot_model
        props = self._properties
        group = props["group"]
        motion = props["direction"]
        jmg = model.group(group)
        timeout = self.timeout_or(1.0)
        max_distance = float(props["max_distance"])
        min_distance = float(props["min_distance"])
        if max_distance > 0.0 and abs(max_distance - min_distance) < _EPS:
            min_distance = -1.0  # equal bounds: move the full distance
        sign = 1.0 if direction != BACKWARD else -1.0
        context = self._context
        extra = self._planning_extras()
        solution = SubTrajectory(None, group, planner_id=self._planner.planner_id)
        if isinstance(motion, dict):
            target = scene.current_state.copy()
            values = target.positions.copy()
            for name, offset in motion.items():
                index = model.variable_index(name)
                values[index] = np.clip(values[index] + sign * offset, model.lower_limits[index], model.upper_limits[index])
            target.set_positions(values)
            scene.set_current_state(target)
            result = self._planner.plan(state.scene, scene, group, timeout, context, **extra)
            success = result.success
            comment = "" if success else result.message
        else:
            link, ik_pose = robot_tip_for_frame(props["ik_frame"], scene, group)
            frame_rotation = frame_transform(scene, motion.frame_id)[:3, :3]
            use_rotation = False
            if isinstance(motion, TwistStamped):
                linear, angular = motion.linear.copy(), motion.angular.copy()
                linear_norm, angular_norm = float(np.linalg.norm(linear)), float(np.linalg.norm(angular))
                if angular_norm > _EPS:
                    angular /= angular_norm
                use_rotation = linear_norm < _EPS
                if use_rotation and angular_norm <= _EPS:
                    return False, scene, SubTrajectory.failure("direction is a zero twist: nothing to move")
                if max_distance > 0.0:
                    scale = max_distance / (angular_norm if use_rotation else linear_norm)
                    linear, linear_norm, angular_norm = linear * scale, linear_norm * scale, angular_norm * scale
                linear, angular = sign * (frame_rotation @ linear), sign * (frame_rotation @ angular)
                rotation = pin.exp3(angular * angular_norm)
                target = ik_pose.copy()
                target[:3, :3] = rotation @ ik_pose[:3, :3]
                target[:3, 3] = ik_pose[:3, 3] + linear
            else:
                linear = motion.vector.copy()
                norm = float(np.linalg.norm(linear))
                if norm < _EPS:
                    return False, scene, SubTrajectory.failure("direction is the zero vector: nothing to move")
                if max_distance > 0.0:
                    linear = linear / norm * max_distance
                linear = sign * (frame_rotation @ linear)
                target = ik_pose.copy()
                target[:3, 3] += linear
            offset = inverse(scene.current_state.frame_pose(link)) @ ik_pose
            result = self._planner.plan_pose(state.scene, link, offset, target, group, timeout, context, **extra)
            success = result.success
            comment = "" if success else result.message
            trajectory = result.trajectory
            if trajectory is not None and len(trajectory) > 0:
                reached_state = state.scene.current_state.copy()
                values = reached_state.positions.copy()
                values[jmg.variable_indices] = trajectory.positions[-1]
                reached_state.set_positions(values)
                reached = reached_state.frame_pose(link) @ offset
                if use_rotation:
                    distance = float(np.linalg.norm(pin.log3(reached[:3, :3] @ ik_pose[:3, :3].T)))
                    unit = "rad"
                else:
                    distance = float(np.linalg.norm(reached[:3, 3] - ik_pose[:3, 3]))
                    unit = "m"
                if min_distance > 0.0:
                    success = distance >= min_distance
                    comment = "" if success else f"min_distance not reached ({distance:.3g} < {min_distance:.3g} {unit})"
                elif min_distance == 0.0:
                    success = True
                    comment = ""
                elif not success:
                    comment = f"failed to move full distance ({distance:.3g} {unit}): {result.message}"
        trajectory = self._planner.dense(result.trajectory)
        solution.planner_id = result.planner_id or solution.planner_id
        return self._finish_propagation(state, scene, solution, trajectory, direction, success,
                                        comment or "planning failed", comment or "planning failed")
