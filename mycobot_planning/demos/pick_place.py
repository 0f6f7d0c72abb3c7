"""The seeds' pick and place (mtc_node, and Example 1 ``pick_place_demo``), ROS-free.

The full story: docs/demos.md, section mycobot_planning.demos.pick_place.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np

from interfaces_py.msgs import CollisionObject

from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.demos import pick_place_parameters
from mycobot_planning.demos.pick_place_parameters import (  # re-exported: their public path before the split
    MTC_NODE_PARAMETER_NAMES as MTC_NODE_PARAMETER_NAMES,
    PARAMETERS as PARAMETERS,
    PICK_PLACE_DEMO_PARAMETERS as PICK_PLACE_DEMO_PARAMETERS,
    TASK_NODE_PARAMETER_NAMES as TASK_NODE_PARAMETER_NAMES,
    ParameterInfo as ParameterInfo,
    PickPlaceParameters,
    load_parameters as load_parameters,
    parameter_problem as parameter_problem,
)
from mycobot_planning.task.containers import SerialContainer
from mycobot_planning.task.geometry import PoseStamped, Vector3Stamped
from mycobot_planning.task.solvers import CartesianPath, JointInterpolationPlanner, PipelinePlanner
from mycobot_planning.task.stage import Stage
from mycobot_planning.task.stages import ComputeIK, Connect, CurrentState, GenerateGraspPose, GeneratePlacePose, ModifyPlanningScene, \
    MoveRelative, MoveTo
from mycobot_planning.task.task import Task

#: the task's public names, and (their public path before the split) the parameters'
__all__ = [
    "build_pick_place_task",
    "expected_place_pose",
    "pick_place_scene",
    "seed_scene_objects",
    "vector_to_pose",
    *pick_place_parameters.__all__,
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
