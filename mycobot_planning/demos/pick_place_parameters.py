"""The parameters of the seeds' pick and place (mtc_node's, and Example 1 ``pick_place_demo``'s):
how each is described and checked, their defaults as one validated dataclass, and reading them
from a ROS parameter file. The task they configure: demos/pick_place.py.

The full story: docs/demos.md, section mycobot_planning.demos.pick_place.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import yaml

__all__ = [
    "MTC_NODE_PARAMETER_NAMES",
    "PARAMETERS",
    "PICK_PLACE_DEMO_PARAMETERS",
    "ParameterInfo",
    "PickPlaceParameters",
    "TASK_NODE_PARAMETER_NAMES",
    "load_parameters",
    "parameter_problem",
]


def _positive_entries(name: str, value: Any) -> str | None:
    if any(not (isinstance(v, (int, float)) and v > 0) for v in value):
        return f"{name} must contain positive sizes (m), got {list(value)}"
    return None


def _non_zero(name: str, value: Any) -> str | None:
    if value == 0:
        return f"{name} must not be 0: it is the z component of a direction vector"
    return None


def _positive(name: str, value: Any) -> str | None:
    if not value > 0:
        return f"{name} must be > 0, got {value}"
    return None


@dataclass(frozen=True)
class ParameterInfo:
    """How a parameter is described and checked (the nodes turn these into ParameterSpecs)."""

    name: str
    description: str
    range: tuple[float, float] | None = None  # inclusive
    array_size: int | None = None
    non_empty: bool = False
    check: Callable[[str, Any], str | None] | None = None  # extra check: (name, value) -> problem

    def problem(self, value: Any) -> str | None:
        """Why ``value`` is not acceptable for this parameter, or None."""
        name = self.name
        if isinstance(value, float) and not math.isfinite(value):
            return f"{name} must be a finite number, got {value}"
        if isinstance(value, (list, tuple)):
            if self.array_size is not None and len(value) != self.array_size:
                return f"{name} must have exactly {self.array_size} values, got {len(value)}"
            if any(isinstance(v, float) and not math.isfinite(v) for v in value):
                return f"{name} must contain finite numbers only"
            if self.non_empty and (len(value) == 0 or any(not isinstance(v, str) or not v.strip() for v in value)):
                return f"{name} must not be empty or contain empty names"
        if isinstance(value, str) and self.non_empty and not value.strip():
            return f"{name} must not be empty"
        if self.range is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
            low, high = self.range
            if not low <= value <= high:
                return f"{name} must be within [{low:g}, {high:g}], got {value}"
        if self.check is not None:
            return self.check(name, value)
        return None


_DIST = (0.0, 2.0)  # metres: the myCobot reaches 0.28 m, 2 m catches unit mistakes (mm for m)
_POSE = "[x, y, z, roll, pitch, yaw] (m, rad; rotations about x, then y, then z)"

#: Every parameter of the seed's mtc_node, in its declaration order, plus Example 1's
#: eef_name / surface_link. Descriptions are the seed's, completed.
PARAMETERS: dict[str, ParameterInfo] = {p.name: p for p in (
    ParameterInfo("execute", "Whether to execute the planned task (setting it true later executes the best solution)"),
    ParameterInfo("max_solutions", "Maximum number of solutions to compute (0: all there are)", range=(0, 1000)),
    ParameterInfo("spawn_table", "Whether to spawn a table in the planning scene (false removes an existing one)"),
    ParameterInfo("controller_names", "Names of the controllers to use", non_empty=True),
    ParameterInfo("arm_group_name", "Name of the arm group in the SRDF", non_empty=True),
    ParameterInfo("gripper_group_name", "Name of the gripper group in the SRDF", non_empty=True),
    ParameterInfo("gripper_frame", "Name of the gripper frame (the link the grasp frame is attached to)", non_empty=True),
    ParameterInfo("gripper_open_pose", "Name of the gripper open pose (SRDF named state)", non_empty=True),
    ParameterInfo("gripper_close_pose", "Name of the gripper closed pose (SRDF named state)", non_empty=True),
    ParameterInfo("arm_home_pose", "Name of the arm home pose (SRDF named state)", non_empty=True),
    ParameterInfo("world_frame", "Name of the world frame", non_empty=True),
    ParameterInfo("table_name", "Name of the table in the planning scene", non_empty=True),
    ParameterInfo("table_reference_frame", "Reference frame for the table", non_empty=True),
    ParameterInfo("table_dimensions", "Dimensions of the table [x, y, z] (m)", array_size=3, check=_positive_entries),
    ParameterInfo("table_pose", f"Pose of the table top {_POSE}", array_size=6),
    ParameterInfo("object_name", "Name of the object to be manipulated", non_empty=True),
    ParameterInfo("object_reference_frame", "Reference frame for the object", non_empty=True),
    ParameterInfo("object_dimensions", "Dimensions of the object [height, radius] (m, a cylinder)", array_size=2,
                  check=_positive_entries),
    ParameterInfo("object_pose", f"Initial pose of the object's base {_POSE}", array_size=6),
    ParameterInfo("grasp_frame_transform", f"Transform from gripper frame to grasp frame {_POSE}", array_size=6),
    ParameterInfo("place_pose", f"Pose where the object should be placed {_POSE}", array_size=6),
    ParameterInfo("place_surface_offset", "Offset from the surface when placing the object (m)", range=(-1.0, 1.0)),
    ParameterInfo("approach_object_min_dist", "Minimum approach distance to the object (m)", range=_DIST),
    ParameterInfo("approach_object_max_dist", "Maximum approach distance to the object (m)", range=_DIST),
    ParameterInfo("lift_object_min_dist", "Minimum lift distance for the object (m)", range=_DIST),
    ParameterInfo("lift_object_max_dist", "Maximum lift distance for the object (m)", range=_DIST),
    ParameterInfo("lower_object_min_dist", "Minimum distance for lowering object (m)", range=_DIST),
    ParameterInfo("lower_object_max_dist", "Maximum distance for lowering object (m)", range=_DIST),
    ParameterInfo("move_to_pick_timeout", "Timeout for move to pick stage (seconds)", range=(0.001, 600.0)),
    ParameterInfo("move_to_place_timeout", "Timeout for move to place stage (seconds)", range=(0.001, 600.0)),
    ParameterInfo("grasp_pose_angle_delta", "Angular resolution for sampling grasp poses (radians)",
                  range=(0.001, 2 * math.pi)),
    ParameterInfo("grasp_pose_max_ik_solutions", "Maximum number of IK solutions for grasp pose generation",
                  range=(1, 100)),
    ParameterInfo("grasp_pose_min_solution_distance",
                  "Minimum distance in joint-space units between IK solutions for grasp pose", range=(0.0, 100.0)),
    ParameterInfo("place_pose_max_ik_solutions", "Maximum number of IK solutions for place pose generation",
                  range=(1, 100)),
    ParameterInfo("cartesian_max_velocity_scaling", "Max velocity scaling factor for Cartesian planner",
                  range=(0.0, 1.0), check=_positive),
    ParameterInfo("cartesian_max_acceleration_scaling", "Max acceleration scaling factor for Cartesian planner",
                  range=(0.0, 1.0), check=_positive),
    ParameterInfo("cartesian_step_size", "Step size for Cartesian planner (m)", range=(0.0, 0.1), check=_positive),
    ParameterInfo("approach_object_direction_z", "Z component of approach object direction vector (gripper frame)",
                  range=(-1.0, 1.0), check=_non_zero),
    ParameterInfo("lift_object_direction_z", "Z component of lift object direction vector (world frame)",
                  range=(-1.0, 1.0), check=_non_zero),
    ParameterInfo("lower_object_direction_z", "Z component of lower object direction vector (world frame)",
                  range=(-1.0, 1.0), check=_non_zero),
    ParameterInfo("retreat_direction_z", "Z component of retreat direction vector (gripper frame)",
                  range=(-1.0, 1.0), check=_non_zero),
    ParameterInfo("place_pose_z_offset_factor", "Factor to multiply object height for place pose Z offset",
                  range=(-10.0, 10.0)),
    ParameterInfo("retreat_min_distance", "Minimum distance for retreat motion (m)", range=_DIST),
    ParameterInfo("retreat_max_distance", "Maximum distance for retreat motion (m)", range=_DIST),
    ParameterInfo("eef_name", "Name of the end effector in the SRDF (Example 1; mtc_node uses gripper_group_name)",
                  non_empty=True),
    ParameterInfo("surface_link", "Name of the support surface the object stands on (Example 1; mtc_node uses "
                                  "table_name)", non_empty=True),
)}

#: The seed's mtc_node parameters (everything in PARAMETERS but Example 1's two and ours).
MTC_NODE_PARAMETER_NAMES: tuple[str, ...] = tuple(n for n in PARAMETERS if n not in ("eef_name", "surface_link"))
#: Parameters every task node has (ros/task/task_node.py) that are not the task's: a parameter
#: file may hold them, load_parameters skips them.
TASK_NODE_PARAMETER_NAMES = frozenset({"exit_when_done", "planning_timeout", "seed", "planning_server",
                                       "server_timeout", "exit_linger",
                                       "use_perception", "perception_server", "perception_timeout"})
#: The seed's Example 1 parameter file (pick_place_demo_parameters.yaml), in its order.
PICK_PLACE_DEMO_PARAMETERS: tuple[str, ...] = (
    "execute", "controller_names", "table_name", "table_reference_frame", "table_dimensions", "table_pose",
    "object_name", "object_reference_frame", "object_dimensions", "object_pose", "spawn_table", "max_solutions",
    "arm_group_name", "eef_name", "gripper_group_name", "gripper_frame", "gripper_open_pose", "gripper_close_pose",
    "arm_home_pose", "world_frame", "surface_link", "grasp_frame_transform", "place_pose", "place_surface_offset",
    "approach_object_min_dist", "approach_object_max_dist", "lift_object_min_dist", "lift_object_max_dist",
)

_MIN_MAX = (("approach_object_min_dist", "approach_object_max_dist"), ("lift_object_min_dist", "lift_object_max_dist"),
            ("lower_object_min_dist", "lower_object_max_dist"), ("retreat_min_distance", "retreat_max_distance"))


def parameter_problem(name: str, value: Any) -> str | None:
    """Why ``value`` is refused for parameter ``name`` (None: fine). Unknown names are refused."""
    info = PARAMETERS.get(name)
    if info is None:
        return f"unknown parameter '{name}'"
    return info.problem(value)


@dataclass(frozen=True)
class PickPlaceParameters:
    """The seed's mtc_node parameters with its defaults; invalid values raise ValueError naming
    every problem (fixed array sizes, non-empty names, ranges, min <= max distances).

    ``eef_name`` / ``surface_link`` are Example 1's; empty means mtc_node's choice (the gripper
    group name / the table name).
    """

    execute: bool = False
    max_solutions: int = 10
    spawn_table: bool = True
    controller_names: tuple[str, ...] = ("arm_controller", "grip_action_controller")
    arm_group_name: str = "arm"
    gripper_group_name: str = "gripper"
    gripper_frame: str = "link6_flange"
    gripper_open_pose: str = "open"
    gripper_close_pose: str = "half_closed"
    arm_home_pose: str = "home"
    world_frame: str = "base_link"
    table_name: str = "table"
    table_reference_frame: str = "base_link"
    table_dimensions: tuple[float, ...] = (0.10, 0.20, 0.03)
    table_pose: tuple[float, ...] = (0.22, 0.12, 0.0, 0.0, 0.0, 0.0)
    object_name: str = "object"
    object_reference_frame: str = "base_link"
    object_dimensions: tuple[float, ...] = (0.35, 0.0125)
    object_pose: tuple[float, ...] = (0.22, 0.12, 0.0, 0.0, 0.0, 0.0)
    grasp_frame_transform: tuple[float, ...] = (0.0, 0.0, 0.096, 1.5708, 0.0, 0.0)
    place_pose: tuple[float, ...] = (-0.183, -0.14, 0.0, 0.0, 0.0, 0.0)
    place_surface_offset: float = -0.03
    approach_object_min_dist: float = 0.0015
    approach_object_max_dist: float = 0.3
    lift_object_min_dist: float = 0.005
    lift_object_max_dist: float = 0.3
    lower_object_min_dist: float = 0.005
    lower_object_max_dist: float = 0.4
    move_to_pick_timeout: float = 5.0
    move_to_place_timeout: float = 10.0
    grasp_pose_angle_delta: float = 0.2618
    grasp_pose_max_ik_solutions: int = 8
    grasp_pose_min_solution_distance: float = 1.0
    place_pose_max_ik_solutions: int = 2
    cartesian_max_velocity_scaling: float = 1.0
    cartesian_max_acceleration_scaling: float = 1.0
    cartesian_step_size: float = 0.00025
    approach_object_direction_z: float = 1.0
    lift_object_direction_z: float = 1.0
    lower_object_direction_z: float = -1.0
    retreat_direction_z: float = -1.0
    place_pose_z_offset_factor: float = 0.5
    retreat_min_distance: float = 0.025
    retreat_max_distance: float = 0.25
    eef_name: str = ""
    surface_link: str = ""

    def __post_init__(self) -> None:
        problems = []
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, (list, tuple, np.ndarray)):
                value = tuple(value.tolist() if isinstance(value, np.ndarray) else value)
                object.__setattr__(self, f.name, value)
            problem = self._type_problem(f.name, value)
            if problem is None and not (f.name in ("eef_name", "surface_link") and value == ""):
                problem = PARAMETERS[f.name].problem(list(value) if isinstance(value, tuple) else value)
            if problem:
                problems.append(problem)
        if not problems:
            for low, high in _MIN_MAX:
                if getattr(self, low) > getattr(self, high):
                    problems.append(f"{low} ({getattr(self, low):g}) must not exceed {high} ({getattr(self, high):g})")
        if problems:
            raise ValueError("invalid pick-and-place parameters: " + "; ".join(problems))

    def _type_problem(self, name: str, value: Any) -> str | None:
        default = next(f.default for f in fields(self) if f.name == name)
        if isinstance(default, bool):
            ok = isinstance(value, bool)
            kind = "true or false"
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
            kind = "an integer"
        elif isinstance(default, float):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if ok:
                object.__setattr__(self, name, float(value))
            kind = "a number"
        elif isinstance(default, str):
            ok = isinstance(value, str)
            kind = "a string"
        elif default and isinstance(default[0], str):
            ok = isinstance(value, tuple) and all(isinstance(v, str) for v in value)
            kind = "a list of strings"
        else:
            ok = isinstance(value, tuple) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
            if ok:
                object.__setattr__(self, name, tuple(float(v) for v in value))
            kind = "a list of numbers"
        return None if ok else f"{name} must be {kind}, got {value!r}"

    # ------------------------------------------------------------------ conveniences
    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], *, ignore_unknown: bool = False) -> "PickPlaceParameters":
        """From a {name: value} map (e.g. a node's parameters); unknown names raise ValueError
        unless ``ignore_unknown``."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(k for k in values if k not in known)
        if unknown and not ignore_unknown:
            raise ValueError(f"unknown pick-and-place parameter(s): {', '.join(unknown)}")
        return cls(**{k: v for k, v in values.items() if k in known})

    def with_changes(self, **changes: Any) -> "PickPlaceParameters":
        """A validated copy with some values changed."""
        return replace(self, **changes)

    def as_dict(self) -> dict[str, Any]:
        return {f.name: (list(getattr(self, f.name)) if isinstance(getattr(self, f.name), tuple)
                         else getattr(self, f.name)) for f in fields(self)}

    @property
    def eef(self) -> str:
        """The end effector the task uses (mtc_node: the gripper group's name)."""
        return self.eef_name or self.gripper_group_name

    @property
    def support_surface(self) -> str:
        """What the object stands on for the allow/forbid collision stages (mtc_node: the table)."""
        return self.surface_link or self.table_name


def load_parameters(path: str | Path, node_name: str | None = None) -> PickPlaceParameters:
    """Parameters from a ROS parameter file (``node: ros__parameters: {...}``, or a plain map).
    Unknown names and bad values raise ValueError naming the file and the problem."""
    with open(path, encoding="utf-8") as handle:
        data = yaml.safe_load(handle) or {}
    if not isinstance(data, Mapping):
        raise ValueError(f"{path}: expected a map of parameters")
    params: Any = data
    if node_name is not None and node_name in data:
        params = data[node_name]
    elif len(data) == 1 and isinstance(next(iter(data.values())), Mapping):
        params = next(iter(data.values()))
    if isinstance(params, Mapping) and "ros__parameters" in params:
        params = params["ros__parameters"] or {}
    if not isinstance(params, Mapping):
        raise ValueError(f"{path}: expected a map of parameters")
    try:
        return PickPlaceParameters.from_mapping({k: v for k, v in params.items() if k not in TASK_NODE_PARAMETER_NAMES})
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None
