"""``moveit.core.robot_model``: moveit_py's RobotModel, JointModelGroup and VariableBounds over the
core RobotModel (the same object a Task or a core PlanningScene uses)."""
from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from mycobot_planning.core.robot_model.robot_model import RobotModel as CoreRobotModel
from mycobot_planning.paths import package_share_dirs

__all__ = ["JointModelGroup", "RobotModel", "VariableBounds", "core_model", "robot_model"]


class VariableBounds:
    """One variable's limits, as moveit_py shows them (read-only)."""

    def __init__(self, min_position: float, max_position: float, max_velocity: float, max_acceleration: float,
                 max_jerk: float | None, has_acceleration_limits: bool) -> None:
        self.min_position = float(min_position)
        self.max_position = float(max_position)
        self.position_bounded = math.isfinite(self.min_position) or math.isfinite(self.max_position)
        self.max_velocity = float(max_velocity)
        self.min_velocity = -self.max_velocity
        self.velocity_bounded = math.isfinite(self.max_velocity)
        self.max_acceleration = float(max_acceleration)
        self.min_acceleration = -self.max_acceleration
        self.acceleration_bounded = bool(has_acceleration_limits)
        self.max_jerk = float(max_jerk) if max_jerk is not None else 0.0
        self.min_jerk = -self.max_jerk
        self.jerk_bounded = max_jerk is not None

    def __repr__(self) -> str:
        return (f"VariableBounds(position=[{self.min_position:g}, {self.max_position:g}], "
                f"velocity={self.max_velocity:g}, acceleration={self.max_acceleration:g})")


class JointModelGroup:
    """A planning group (moveit_py's JointModelGroup)."""

    def __init__(self, model: CoreRobotModel, name: str) -> None:
        self._model = model
        self._group = model.group(name)

    @property
    def name(self) -> str:
        return self._group.name

    @property
    def joint_model_names(self) -> list[str]:
        return list(self._group.all_joint_names)

    @property
    def active_joint_model_names(self) -> list[str]:
        return list(self._group.joint_names)

    @property
    def link_model_names(self) -> list[str]:
        return list(self._group.link_names)

    @property
    def eef_name(self) -> str:
        return self._group.end_effector or ""

    @property
    def active_joint_model_bounds(self) -> list[list[VariableBounds]]:
        """One list of VariableBounds per active joint (one variable each here)."""
        out = []
        for name in self._group.joint_names:
            j = self._model.joint(name)
            out.append([VariableBounds(j.lower, j.upper, j.max_velocity, j.max_acceleration, j.max_jerk,
                                       j.has_acceleration_limits)])
        return out

    def satisfies_position_bounds(self, values: Sequence[float], margin: float = 0.0) -> bool:
        """True when ``values`` (one per active joint, in group order) are inside the limits."""
        v = np.asarray(values, dtype=float).reshape(-1)
        if v.shape[0] != self._group.variable_count:
            raise ValueError(f"group '{self.name}' has {self._group.variable_count} variables, got {v.shape[0]} values")
        idx = self._group.variable_indices
        return bool(np.all(v >= self._model.lower_limits[idx] - margin) and
                    np.all(v <= self._model.upper_limits[idx] + margin))

    def __repr__(self) -> str:
        return f"JointModelGroup({self.name!r}, joints={self.active_joint_model_names})"


class RobotModel:
    """moveit_py's RobotModel: ``RobotModel(urdf_xml_path, srdf_xml_path)``, or the model MoveItPy
    and a Task load (``get_robot_model()``, ``task.getRobotModel()``)."""

    def __init__(self, urdf_xml_path: str, srdf_xml_path: str) -> None:
        self._model = CoreRobotModel.from_files(urdf_xml_path, srdf_xml_path, package_dirs=package_share_dirs())

    @classmethod
    def _wrap(cls, model: CoreRobotModel) -> "RobotModel":
        wrapper = cls.__new__(cls)
        wrapper._model = model
        return wrapper

    @property
    def name(self) -> str:
        return self._model.name

    @property
    def model_frame(self) -> str:
        """The frame everything is expressed in (the root link's parent: the SRDF's virtual joint
        frame, usually "world")."""
        return self._model.srdf.virtual_joints[0].parent_frame if self._model.srdf.virtual_joints else "world"

    @property
    def root_joint_name(self) -> str:
        return self._model.srdf.virtual_joints[0].name if self._model.srdf.virtual_joints else "ASSUMED_FIXED_ROOT_JOINT"

    @property
    def joint_model_group_names(self) -> list[str]:
        return list(self._model.group_names)

    @property
    def joint_model_groups(self) -> list[JointModelGroup]:
        return [JointModelGroup(self._model, n) for n in self._model.group_names]

    @property
    def end_effectors(self) -> list[JointModelGroup]:
        return [JointModelGroup(self._model, e.group) for e in self._model.end_effectors.values()]

    def has_joint_model_group(self, joint_model_group_name: str) -> bool:
        return self._model.has_group(joint_model_group_name)

    def get_joint_model_group(self, joint_model_group_name: str) -> JointModelGroup | None:
        """The group, or None when the robot has none of that name (as moveit_py)."""
        if not self._model.has_group(joint_model_group_name):
            return None
        return JointModelGroup(self._model, joint_model_group_name)

    def get_model_info(self) -> str:
        lines = [f"Model {self.name} in frame {self.model_frame}"]
        for name, low, high in zip(self._model.variable_names, self._model.lower_limits, self._model.upper_limits):
            lines.append(f"  {name} [{low:g}, {high:g}]")
        lines.extend(f"  group {g}: {list(self._model.group(g).joint_names)}" for g in self._model.group_names)
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"RobotModel({self.name!r}, groups={self.joint_model_group_names})"


def unwrap(value: Any, wrapper: type, core_type: type, attribute: str) -> Any:
    """The core object a moveit_py ``wrapper`` holds in ``attribute`` (a core one: itself); a
    TypeError for anything else."""
    if isinstance(value, wrapper):
        return getattr(value, attribute)
    if isinstance(value, core_type):
        return value
    raise TypeError(f"expected a {wrapper.__name__}, got {type(value).__name__}")


def core_model(model: Any) -> CoreRobotModel:
    """The core RobotModel of a moveit_py RobotModel (or of a core one: itself)."""
    return unwrap(model, RobotModel, CoreRobotModel, "_model")


def robot_model(model: Any) -> RobotModel:
    """The moveit_py RobotModel of a core RobotModel (or of a moveit_py one: itself)."""
    return model if isinstance(model, RobotModel) else RobotModel._wrap(core_model(model))
