"""The seeds' pick and place (mtc_node, and Example 1 ``pick_place_demo``), ROS-free.

The full story: docs/demos.md, section mycobot_planning.demos.pick_place.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import yaml

from interfaces_py.msgs import CollisionObject

from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.task.containers import SerialContainer
from mycobot_planning.task.geometry import PoseStamped, Vector3Stamped
from mycobot_planning.task.solvers import CartesianPath, JointInterpolationPlanner, PipelinePlanner
from mycobot_planning.task.stage import Stage
from mycobot_planning.task.stages import ComputeIK, Connect, CurrentState, GenerateGraspPose, GeneratePlacePose, ModifyPlanningScene, \
    MoveRelative, MoveTo
from mycobot_planning.task.task import Task

__all__ = [
    "PARAMETERS",
    "PICK_PLACE_DEMO_PARAMETERS",
    "ParameterInfo",
    "PickPlaceParameters",
    "build_pick_place_task",
    "expected_place_pose",
    "load_parameters",
    "parameter_problem",
    "pick_place_scene",
    "seed_scene_objects",
    "vector_to_pose",
]

TASK_NAME = "pick_place_task"


# ---------------------------------------------------------------------------- poses
def vector_to_pose(values: Sequence[float]) -> np.ndarray:
    """[x, y, z, roll, pitch, yaw] → 4x4, as the seeds convert their parameter vectors:
    translation, then rotation about x by roll, about the *new* y by pitch, about the new z by
    yaw (R = Rx Ry Rz). Raises ValueError unless there are 6 finite numbers."""
    v = np.asarray(values, dtype=float).reshape(-1)
    if v.size != 6 or not np.all(np.isfinite(v)):
        raise ValueError(f"a pose vector needs 6 finite numbers [x, y, z, roll, pitch, yaw], got {list(values)!r}")
    cr, sr = math.cos(v[3]), math.sin(v[3])
    cp, sp = math.cos(v[4]), math.sin(v[4])
    cy, sy = math.cos(v[5]), math.sin(v[5])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    pose = np.eye(4)
    pose[:3, :3] = rx @ ry @ rz
    pose[:3, 3] = v[:3]
    return pose


# ---------------------------------------------------------------------------- parameters
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


# ---------------------------------------------------------------------------- scene
def seed_scene_objects(params: PickPlaceParameters) -> tuple[CollisionObject | None, CollisionObject]:
    """The table (None when ``spawn_table`` is false) and the cylinder, posed as the seed does:
    the table's centre half its height below ``table_pose`` (its top on the pose), the
    cylinder's centre ``place_pose_z_offset_factor`` x height above ``object_pose``."""
    table = None
    if params.spawn_table:
        pose = vector_to_pose(params.table_pose)
        pose[2, 3] -= 0.5 * params.table_dimensions[2]
        table = CollisionObject.box(params.table_name, list(params.table_dimensions), pose,
                                    frame_id=params.table_reference_frame)
    pose = vector_to_pose(params.object_pose)
    pose[2, 3] += params.place_pose_z_offset_factor * params.object_dimensions[0]
    height, radius = params.object_dimensions
    cylinder = CollisionObject.cylinder(params.object_name, height, radius, pose, frame_id=params.object_reference_frame)
    return table, cylinder


def expected_place_pose(params: PickPlaceParameters) -> np.ndarray:
    """Where the object's centre goes (in ``world_frame``): ``place_pose`` raised by
    ``place_pose_z_offset_factor`` x height + ``place_surface_offset``, as the seed's place
    pose generator target. A cylinder may end rotated about its axis (the generator tries ten
    rotations); its position and axis are what the task fixes."""
    pose = vector_to_pose(params.place_pose)
    pose[2, 3] += params.place_pose_z_offset_factor * params.object_dimensions[0] + params.place_surface_offset
    return pose


def pick_place_scene(model: RobotModel, params: PickPlaceParameters | None = None,
                     state: RobotState | None = None) -> PlanningScene:
    """A ROS-free scene as the node sets it up: ``state`` (default: every joint 0, i.e. the arm
    'home' and the gripper 'open', as the mock controllers start) with the seed's objects."""
    params = params or PickPlaceParameters()
    scene = PlanningScene(model)
    if state is not None:
        scene.set_current_state(state)
    table, cylinder = seed_scene_objects(params)
    if table is not None:
        scene.apply_collision_object(table)
    scene.apply_collision_object(cylinder)
    return scene


# ---------------------------------------------------------------------------- task
def _check_model(model: RobotModel, params: PickPlaceParameters) -> None:
    """The names the task needs exist in the robot model (one ValueError naming all that don't)."""
    problems = []
    for key in ("arm_group_name", "gripper_group_name"):
        name = getattr(params, key)
        if not model.has_group(name):
            problems.append(f"{key}: no planning group '{name}' (known: {', '.join(model.group_names)})")
    if model.has_group(params.gripper_group_name):
        for key in ("gripper_open_pose", "gripper_close_pose"):
            name = getattr(params, key)
            if name not in model.named_state_names(params.gripper_group_name):
                problems.append(f"{key}: group '{params.gripper_group_name}' has no named state '{name}' (known: "
                                f"{', '.join(model.named_state_names(params.gripper_group_name))})")
    if model.has_group(params.arm_group_name) and params.arm_home_pose not in model.named_state_names(params.arm_group_name):
        problems.append(f"arm_home_pose: group '{params.arm_group_name}' has no named state '{params.arm_home_pose}' "
                        f"(known: {', '.join(model.named_state_names(params.arm_group_name))})")
    if not model.has_link(params.gripper_frame):
        problems.append(f"gripper_frame: robot '{model.name}' has no link '{params.gripper_frame}'")
    if params.eef not in model.end_effectors:
        which = "eef_name" if params.eef_name else "gripper_group_name (the end effector mtc_node uses)"
        problems.append(f"{which}: no end effector '{params.eef}' (known: {', '.join(model.end_effectors) or 'none'})")
    if problems:
        raise ValueError("the parameters do not fit the robot model: " + "; ".join(problems))


#: IK time budget per grasp / place target (s): ours, the seed leaves it to MTC (see
#: build_pick_place_task). ComputeIK's own stopping rules usually end the search sooner.
GRASP_IK_TIMEOUT = 0.02
PLACE_IK_TIMEOUT = 0.02


def build_pick_place_task(model: RobotModel, params: PickPlaceParameters | None = None,
                          scene_or_provider: PlanningScene | Callable[[float], PlanningScene] | None = None, *,
                          seed: int | None = 0, grasp_ik_timeout: float | None = GRASP_IK_TIMEOUT,
                          place_ik_timeout: float | None = PLACE_IK_TIMEOUT) -> Task:
    """The seed's "pick_place_task", ready to ``plan(params.max_solutions)``.

    ``scene_or_provider``: the start scene (a PlanningScene, e.g. :func:`pick_place_scene`) or
    a callable ``fetch(timeout) -> PlanningScene`` that asks the planning_server each time the
    task plans (None: :func:`pick_place_scene` with every joint at 0). ``seed`` makes the
    sampling reproducible (None: random).

    ``grasp_ik_timeout`` / ``place_ik_timeout``: the IK time budget per grasp / place target
    (None: the group's kinematics_solver_timeout, 0.05 s). The seed leaves it to MTC, whose
    ComputeIK spends its whole 1 s timeout on every target with fewer than
    ``max_ik_solutions`` solutions (most of the seed's 8.7 s). Our ComputeIK stops earlier: a
    target none of its first 16 attempts reaches is out of reach (a few ms; 17 of the 24 grasp
    angles here), and otherwise once 100 restarts in a row find no new solution (~13 ms here).
    20 ms only bounds that search on a slow or loaded machine.

    Raises ValueError when the parameters name groups, states, links or an end effector the
    model lacks; the Task's init() reports anything else per stage.
    """
    params = params or PickPlaceParameters()
    _check_model(model, params)
    if scene_or_provider is None:
        scene_or_provider = pick_place_scene(model, params)
    p = params
    controllers = list(p.controller_names)
    task = Task(TASK_NAME, model, seed=seed)
    if isinstance(scene_or_provider, PlanningScene):
        task.setScene(scene_or_provider)
    elif callable(scene_or_provider):
        task.setSceneProvider(scene_or_provider)
    else:
        raise ValueError(f"expected a PlanningScene or a callable scene provider, got {type(scene_or_provider).__name__}")

    ompl_planner_arm = PipelinePlanner({"ompl": f"{p.arm_group_name}[RRTConnectkConfigDefault]"})
    interpolation_planner = JointInterpolationPlanner()
    cartesian_planner = CartesianPath()
    cartesian_planner.setMaxVelocityScalingFactor(p.cartesian_max_velocity_scaling)
    cartesian_planner.setMaxAccelerationScalingFactor(p.cartesian_max_acceleration_scaling)
    cartesian_planner.setStepSize(p.cartesian_step_size)

    task.setProperty("trajectory_execution_info", controllers)
    task.setProperty("group", p.arm_group_name)
    task.setProperty("eef", p.eef)
    task.setProperty("ik_frame", p.gripper_frame)

    current_state = CurrentState("current state")
    task.add(current_state)

    task.add(_move_gripper("open gripper", interpolation_planner, p.gripper_group_name, p.gripper_open_pose,
                           controllers))

    connect_planners = [(p.arm_group_name, ompl_planner_arm), (p.gripper_group_name, interpolation_planner)]
    task.add(_connect("move to pick", connect_planners, p.move_to_pick_timeout))

    # ---- pick object
    grasp = _serial_container(task, "pick object")
    grasp.insert(_move_relative("approach object", cartesian_planner, controllers, "approach_object",
                                p.gripper_frame, p.approach_object_min_dist, p.approach_object_max_dist,
                                Vector3Stamped(p.gripper_frame, [0.0, 0.0, p.approach_object_direction_z])))

    generator = GenerateGraspPose("generate grasp pose")
    generator.properties.configureInitFrom(Stage.PARENT)
    generator.setMarkerNS("grasp_pose")
    generator.setPreGraspPose(p.gripper_open_pose)
    generator.setObject(p.object_name)
    generator.setAngleDelta(p.grasp_pose_angle_delta)
    generator.setMonitoredStage(current_state)
    grasp_frame = vector_to_pose(p.grasp_frame_transform)
    ik = _compute_ik("grasp pose IK", generator, p.grasp_pose_max_ik_solutions, grasp_frame, p.gripper_frame,
                     grasp_ik_timeout)
    ik.setMinSolutionDistance(p.grasp_pose_min_solution_distance)
    grasp.insert(ik)

    stage = ModifyPlanningScene("allow collision (gripper,object)")
    stage.allowCollisions(p.object_name, _collision_links(model, p.gripper_group_name), True)
    grasp.insert(stage)

    grasp.insert(_move_gripper("close gripper", interpolation_planner, p.gripper_group_name, p.gripper_close_pose,
                               controllers))

    attach_object_stage = ModifyPlanningScene("attach object")
    attach_object_stage.attachObject(p.object_name, p.gripper_frame)
    grasp.insert(attach_object_stage)

    stage = ModifyPlanningScene("allow collision (object,support)")
    stage.allowCollisions([p.object_name], [p.support_surface], True)
    grasp.insert(stage)

    grasp.insert(_move_relative("lift object", cartesian_planner, controllers, "lift_object", p.gripper_frame,
                                p.lift_object_min_dist, p.lift_object_max_dist,
                                Vector3Stamped(p.world_frame, [0.0, 0.0, p.lift_object_direction_z])))

    stage = ModifyPlanningScene("forbid collision (object,surface)")
    stage.allowCollisions([p.object_name], [p.support_surface], False)
    grasp.insert(stage)
    task.add(grasp)

    # ---- move to place
    task.add(_connect("move to place", connect_planners, p.move_to_place_timeout))

    # ---- place object
    place = _serial_container(task, "place object")
    place.insert(_move_relative("lower object", cartesian_planner, controllers, "lower_object", p.gripper_frame,
                                p.lower_object_min_dist, p.lower_object_max_dist,
                                Vector3Stamped(p.world_frame, [0.0, 0.0, p.lower_object_direction_z])))

    generator = GeneratePlacePose("generate place pose")
    generator.properties.configureInitFrom(Stage.PARENT, ["ik_frame"])
    generator.setMarkerNS("place_pose")
    generator.setObject(p.object_name)
    generator.setPose(PoseStamped(p.world_frame, expected_place_pose(p)))
    generator.setMonitoredStage(attach_object_stage)  # hook into successful pick solutions
    place.insert(_compute_ik("place pose IK", generator, p.place_pose_max_ik_solutions, grasp_frame, p.gripper_frame,
                             place_ik_timeout))
    place.insert(_move_gripper("open gripper", interpolation_planner, p.gripper_group_name, p.gripper_open_pose,
                               controllers))

    stage = ModifyPlanningScene("forbid collision (gripper,object)")
    stage.allowCollisions(p.object_name, model.group(p.gripper_group_name), False)
    place.insert(stage)

    stage = ModifyPlanningScene("detach object")
    stage.detachObject(p.object_name, p.gripper_frame)
    place.insert(stage)

    place.insert(_move_relative("retreat after place", cartesian_planner, controllers, "retreat", p.gripper_frame,
                                p.retreat_min_distance, p.retreat_max_distance,
                                Vector3Stamped(p.gripper_frame, [0.0, 0.0, p.retreat_direction_z])))
    task.add(place)

    # ---- move home
    stage = MoveTo("move home", ompl_planner_arm)
    stage.setTrajectoryExecutionInfo(controllers)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setGoal(p.arm_home_pose)
    task.add(stage)
    return task


def _collision_links(model: RobotModel, group: str) -> list[str]:
    """The group's links that have collision geometry (MoveIt's
    getLinkModelNamesWithCollisionGeometry)."""
    with_geometry = set(model.links_with_collision_geometry())
    return [link for link in model.group(group).link_names if link in with_geometry]


def _move_gripper(name: str, planner: JointInterpolationPlanner, group: str, goal: str,
                  controllers: list[str]) -> MoveTo:
    """A MoveTo of the gripper group to a named pose."""
    stage = MoveTo(name, planner)
    stage.setGroup(group)
    stage.setGoal(goal)
    stage.setTrajectoryExecutionInfo(controllers)
    return stage


def _connect(name: str, planners: list[tuple[str, Any]], timeout: float) -> Connect:
    """A Connect stage with the given per-group planners, initialised from its parent."""
    stage = Connect(name, planners)
    stage.setTimeout(timeout)
    stage.properties.configureInitFrom(Stage.PARENT)
    return stage


def _serial_container(task: Task, name: str) -> SerialContainer:
    """A SerialContainer that gets the task's eef, group and ik_frame."""
    container = SerialContainer(name)
    task.properties.exposeTo(container.properties, ["eef", "group", "ik_frame"])
    container.properties.configureInitFrom(Stage.PARENT, ["eef", "group", "ik_frame"])
    return container


def _move_relative(name: str, planner: CartesianPath, controllers: list[str], marker_ns: str, ik_frame: str,
                   min_distance: float, max_distance: float, direction: Vector3Stamped) -> MoveRelative:
    """A Cartesian MoveRelative of the group inherited from the parent."""
    stage = MoveRelative(name, planner)
    stage.setMarkerNS(marker_ns)
    stage.setIKFrame(ik_frame)
    stage.setTrajectoryExecutionInfo(controllers)
    stage.properties.configureInitFrom(Stage.PARENT, ["group"])
    stage.setMinMaxDistance(min_distance, max_distance)
    stage.setDirection(direction)
    return stage


def _compute_ik(name: str, generator: Stage, max_solutions: int, ik_frame: np.ndarray, link: str,
                timeout: float | None) -> ComputeIK:
    """A ComputeIK wrapping a pose generator (timeout None: the group's kinematics timeout)."""
    ik = ComputeIK(name, generator)
    ik.setMaxIKSolutions(max_solutions)
    ik.setIKFrame(ik_frame, link)
    if timeout is not None:
        ik.setTimeout(timeout)
    ik.properties.configureInitFrom(Stage.PARENT, ["eef", "group"])
    ik.properties.configureInitFrom(Stage.INTERFACE, ["target_pose"])
    return ik
