"""moveit_msgs <-> the JSON form of interfaces_py.msgs: the one translation between MoveIt's wire
types and what the planning core reads.

The planning core takes requests in the JSON form (dicts with the schema of interfaces_py.msgs),
which the JSON face decodes from std_msgs/String; the MoveIt face (ros/move_group/move_group.py)
translates moveit_msgs messages into the same dicts here, so a request is interpreted in one
place only: the core. Nothing here imports rclpy; only the generated message classes.
"""
from __future__ import annotations

import math
from array import array
from typing import Any, Mapping, Sequence

from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point, Pose as PoseMsg
from moveit_msgs.msg import (
    AllowedCollisionEntry,
    AllowedCollisionMatrix,
    AttachedCollisionObject,
    CollisionObject,
    Constraints,
    MoveItErrorCodes,
    PlanningScene,
    RobotState,
    RobotTrajectory,
)
from shape_msgs.msg import Mesh, MeshTriangle, SolidPrimitive
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .ros_message_reading import ConversionError, collision_object_from_msg, pose_from_msg

#: rad: an orientation constraint this loose on every axis leaves the orientation free
FREE_ORIENTATION = math.pi


# ----------------------------------------------------------------------------- small types


def pose_to_msg(pose: Mapping[str, Sequence[float]]) -> PoseMsg:
    msg = PoseMsg()
    (msg.position.x, msg.position.y, msg.position.z) = (float(v) for v in pose["position"])
    (msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w) = (
        float(v) for v in pose["orientation"])
    return msg


def duration_to_msg(seconds: float) -> Duration:
    nanoseconds = int(round(max(0.0, float(seconds)) * 1e9))
    return Duration(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def duration_from_msg(msg: Duration) -> float:
    return msg.sec + msg.nanosec * 1e-9


def error_code_to_msg(code: Mapping[str, Any] | None) -> MoveItErrorCodes:
    msg = MoveItErrorCodes()
    code = code or {}
    msg.val = int(code.get("val", MoveItErrorCodes.FAILURE))
    msg.message = str(code.get("message", ""))
    msg.source = str(code.get("source", ""))
    return msg


# ----------------------------------------------------------------------------- scene objects


def _primitive_to_msg(data: Mapping[str, Any]) -> SolidPrimitive:
    return SolidPrimitive(type=int(data["type"]), dimensions=[float(d) for d in data["dimensions"]])


def _mesh_to_msg(data: Mapping[str, Any]) -> Mesh:
    msg = Mesh()
    msg.vertices = [Point(x=float(v[0]), y=float(v[1]), z=float(v[2])) for v in data.get("vertices", [])]
    msg.triangles = [MeshTriangle(vertex_indices=[int(i) for i in t]) for t in data.get("triangles", [])]
    return msg


def collision_object_to_msg(data: Mapping[str, Any], stamp: Any = None) -> CollisionObject:
    msg = CollisionObject()
    msg.id = str(data["id"])
    msg.header.frame_id = str(data.get("frame_id", "world"))
    if stamp is not None:
        msg.header.stamp = stamp
    msg.pose = pose_to_msg(data.get("pose") or {"position": [0, 0, 0], "orientation": [0, 0, 0, 1]})
    msg.primitives = [_primitive_to_msg(p) for p in data.get("primitives", [])]
    msg.primitive_poses = [pose_to_msg(p) for p in data.get("primitive_poses", [])]
    msg.meshes = [_mesh_to_msg(m) for m in data.get("meshes", [])]
    msg.mesh_poses = [pose_to_msg(p) for p in data.get("mesh_poses", [])]
    msg.operation = bytes([int(data.get("operation", 0))])
    return msg


def attached_object_from_msg(msg: AttachedCollisionObject) -> dict[str, Any]:
    return {"link_name": msg.link_name, "object": collision_object_from_msg(msg.object),
            "touch_links": list(msg.touch_links), "weight": float(msg.weight)}


def attached_object_to_msg(data: Mapping[str, Any]) -> AttachedCollisionObject:
    msg = AttachedCollisionObject()
    msg.link_name = str(data["link_name"])
    msg.object = collision_object_to_msg(data["object"])
    msg.touch_links = [str(t) for t in data.get("touch_links", [])]
    msg.weight = float(data.get("weight", 0.0))
    return msg


# ----------------------------------------------------------------------------- states and scenes
def robot_state_from_msg(msg: RobotState) -> dict[str, Any] | None:
    """None for an empty, diff start state ("start from the current state", MoveIt's default)."""
    js = msg.joint_state
    names = list(js.name)
    positions = [float(v) for v in js.position]
    if len(positions) != len(names):
        raise ConversionError(MoveItErrorCodes.INVALID_ROBOT_STATE,
                              f"robot state: joint_state has {len(names)} names but {len(positions)} positions")
    if len(msg.multi_dof_joint_state.joint_names):
        raise ConversionError(MoveItErrorCodes.INVALID_ROBOT_STATE,
                              "robot state: multi-DOF joint states are not supported (the robot's joints are "
                              "single-DOF)")
    attached = [attached_object_from_msg(a) for a in msg.attached_collision_objects]
    if not names and not attached:
        return None
    return {"joint_names": names, "positions": positions, "attached_collision_objects": attached,
            "is_diff": bool(msg.is_diff)}


def robot_state_to_msg(data: Mapping[str, Any], stamp: Any = None) -> RobotState:
    msg = RobotState()
    msg.joint_state.name = [str(n) for n in data.get("joint_names", [])]
    msg.joint_state.position = [float(v) for v in data.get("positions", [])]
    msg.joint_state.velocity = [float(v) for v in data.get("velocities", [])]
    if stamp is not None:
        msg.joint_state.header.stamp = stamp
    msg.attached_collision_objects = [attached_object_to_msg(a) for a in data.get("attached_collision_objects", [])]
    msg.is_diff = bool(data.get("is_diff", False))
    return msg


def acm_from_msg(msg: AllowedCollisionMatrix) -> dict[str, Any]:
    return {"entry_names": list(msg.entry_names),
            "entry_values": [[bool(v) for v in e.enabled] for e in msg.entry_values],
            "default_entry_names": list(msg.default_entry_names),
            "default_entry_values": [bool(v) for v in msg.default_entry_values]}


def acm_to_msg(data: Mapping[str, Any]) -> AllowedCollisionMatrix:
    msg = AllowedCollisionMatrix()
    msg.entry_names = [str(n) for n in data.get("entry_names", [])]
    msg.entry_values = [AllowedCollisionEntry(enabled=[bool(v) for v in row]) for row in data.get("entry_values", [])]
    msg.default_entry_names = [str(n) for n in data.get("default_entry_names", [])]
    msg.default_entry_values = [bool(v) for v in data.get("default_entry_values", [])]
    return msg


def planning_scene_from_msg(msg: PlanningScene) -> dict[str, Any]:
    """A scene (or scene diff) in the JSON form apply_planning_scene reads."""
    if len(msg.world.octomap.octomap.data):
        raise ConversionError(MoveItErrorCodes.FAILURE, "planning scene: octomaps are not supported")
    data: dict[str, Any] = {"is_diff": bool(msg.is_diff), "name": msg.name,
                            "world": {"collision_objects": [collision_object_from_msg(o)
                                                            for o in msg.world.collision_objects]}}
    state = robot_state_from_msg(msg.robot_state)
    if state is not None:
        data["robot_state"] = state
    elif not msg.is_diff:
        data["robot_state"] = {"joint_names": [], "positions": [], "is_diff": True}
    if len(msg.allowed_collision_matrix.entry_names) or len(msg.allowed_collision_matrix.default_entry_names):
        data["allowed_collision_matrix"] = acm_from_msg(msg.allowed_collision_matrix)
    return data


def planning_scene_to_msg(data: Mapping[str, Any], components: int | None = None, stamp: Any = None,
                          diff: bool = False) -> PlanningScene:
    """Our scene as moveit_msgs/PlanningScene; ``components`` is the PlanningSceneComponents
    bitmask of a GetPlanningScene request (None: everything); ``diff``: a scene diff (objects keep
    their operations, the robot state is a diff)."""
    from moveit_msgs.msg import PlanningSceneComponents as C

    every = components is None or components == 0
    want = (lambda bit: True) if every else (lambda bit: bool(components & bit))
    msg = PlanningScene()
    msg.name = str(data.get("name", ""))
    msg.robot_model_name = str(data.get("robot_model_name", ""))
    msg.is_diff = bool(diff)
    state = data.get("robot_state") or {}
    if want(C.ROBOT_STATE) or want(C.ROBOT_STATE_ATTACHED_OBJECTS):
        full = robot_state_to_msg(state, stamp)
        if not want(C.ROBOT_STATE):
            full.joint_state.name, full.joint_state.position, full.joint_state.velocity = [], [], []
        if not want(C.ROBOT_STATE_ATTACHED_OBJECTS):
            full.attached_collision_objects = []
        full.is_diff = bool(diff) or full.is_diff
        msg.robot_state = full
    world = (data.get("world") or {}).get("collision_objects", [])
    if want(C.WORLD_OBJECT_GEOMETRY) or want(C.WORLD_OBJECT_NAMES):
        objects = []
        for o in world:
            obj = collision_object_to_msg(o, stamp)
            if not want(C.WORLD_OBJECT_GEOMETRY):
                obj.primitives, obj.primitive_poses, obj.meshes, obj.mesh_poses = [], [], [], []
            objects.append(obj)
        msg.world.collision_objects = objects
    msg.world.octomap.header.frame_id = str(data.get("fixed_frame", "world"))
    if want(C.ALLOWED_COLLISION_MATRIX) and data.get("allowed_collision_matrix"):
        msg.allowed_collision_matrix = acm_to_msg(data["allowed_collision_matrix"])
    return msg


# ----------------------------------------------------------------------------- trajectories
def joint_trajectory_to_msg(data: Mapping[str, Any]) -> JointTrajectory:
    msg = JointTrajectory()
    msg.joint_names = [str(n) for n in data["joint_names"]]
    points = []
    for p in data["points"]:
        point = JointTrajectoryPoint()
        # array('d'): the generated setters and the C conversion take it without a per-value check
        point.positions = array("d", p["positions"])
        point.velocities = array("d", p.get("velocities", ()))
        point.accelerations = array("d", p.get("accelerations", ()))
        point.time_from_start = duration_to_msg(p.get("time_from_start", 0.0))
        points.append(point)
    msg.points = points
    return msg


def joint_trajectory_from_msg(msg: JointTrajectory) -> dict[str, Any]:
    return {"joint_names": list(msg.joint_names),
            "points": [{"positions": [float(v) for v in p.positions],
                        "velocities": [float(v) for v in p.velocities],
                        "accelerations": [float(v) for v in p.accelerations],
                        "time_from_start": duration_from_msg(p.time_from_start)} for p in msg.points]}


def robot_trajectory_to_msg(data: Mapping[str, Any] | None, frame_id: str = "world") -> RobotTrajectory:
    msg = RobotTrajectory()
    if data:
        msg.joint_trajectory = joint_trajectory_to_msg(data["joint_trajectory"])
        msg.joint_trajectory.header.frame_id = frame_id
    return msg


def robot_trajectory_from_msg(msg: RobotTrajectory) -> dict[str, Any]:
    if len(msg.multi_dof_joint_trajectory.points):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                              "trajectory: multi-DOF trajectories are not supported (the robot's joints are "
                              "single-DOF)")
    if not len(msg.joint_trajectory.points):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN, "trajectory: joint_trajectory has no points")
    return {"joint_trajectory": joint_trajectory_from_msg(msg.joint_trajectory)}


# ----------------------------------------------------------------------------- goals
def _region_tolerance(constraint: Any) -> float:
    """Position tolerance of a PositionConstraint's region: a sphere's radius, a box's smallest
    half extent (the goal is the region's centre; the planner lands within this of it)."""
    region = constraint.constraint_region
    tolerances = []
    for primitive in region.primitives:
        dims = list(primitive.dimensions)
        if primitive.type == SolidPrimitive.SPHERE and dims:
            tolerances.append(dims[0])
        elif primitive.type == SolidPrimitive.BOX and len(dims) == 3:
            tolerances.append(min(dims) / 2)
        elif primitive.type in (SolidPrimitive.CYLINDER, SolidPrimitive.CONE) and len(dims) == 2:
            tolerances.append(min(dims[0] / 2, dims[1]))
    return max(min(tolerances), 1e-6) if tolerances else 1e-3


def goal_from_constraints(constraints: Constraints) -> dict[str, Any]:
    """One goal of the core's form from one moveit_msgs/Constraints: joint constraints -> a joint
    goal; a position constraint (with or without an orientation constraint on the same link) ->
    a pose goal in the constraint's frame."""
    joints = list(constraints.joint_constraints)
    positions = list(constraints.position_constraints)
    orientations = list(constraints.orientation_constraints)
    bad = MoveItErrorCodes.INVALID_GOAL_CONSTRAINTS
    if len(constraints.visibility_constraints):
        raise ConversionError(bad, "visibility constraints are not supported as goals")
    if joints and (positions or orientations):
        raise ConversionError(bad, "a goal mixing joint constraints with position/orientation constraints is not "
                                   "supported; send them as separate goal_constraints")
    if joints:
        values = {}
        tolerance = 0.0
        for jc in joints:
            values[jc.joint_name] = float(jc.position)
            tolerance = max(tolerance, float(jc.tolerance_above), float(jc.tolerance_below))
        return {"joints": values, "tolerance": tolerance if tolerance > 0 else 1e-4}
    if not positions and not orientations:
        raise ConversionError(bad, "goal constraints are empty")
    if len(positions) > 1 or len(orientations) > 1:
        raise ConversionError(bad, "a goal may hold one position and one orientation constraint")
    pc = positions[0] if positions else None
    oc = orientations[0] if orientations else None
    if pc is None:
        raise ConversionError(bad, "an orientation-only goal is not supported; add a position constraint")
    if oc is not None and oc.link_name != pc.link_name:
        raise ConversionError(bad, f"position constraint on '{pc.link_name}' and orientation constraint on "
                                   f"'{oc.link_name}': a goal constrains one link")
    region = pc.constraint_region
    if not len(region.primitive_poses) and not len(region.mesh_poses):
        raise ConversionError(bad, "position constraint: constraint_region has no primitive pose")
    centre = region.primitive_poses[0] if len(region.primitive_poses) else region.mesh_poses[0]
    position = [centre.position.x, centre.position.y, centre.position.z]
    if oc is not None:
        q = oc.orientation
        orientation = [q.x, q.y, q.z, q.w]
        orientation_tolerance = max(float(oc.absolute_x_axis_tolerance), float(oc.absolute_y_axis_tolerance),
                                    float(oc.absolute_z_axis_tolerance))
        if oc.header.frame_id and pc.header.frame_id and oc.header.frame_id != pc.header.frame_id:
            raise ConversionError(bad, f"position constraint in '{pc.header.frame_id}' and orientation constraint "
                                       f"in '{oc.header.frame_id}': give both in one frame")
    else:
        orientation = [0.0, 0.0, 0.0, 1.0]
        orientation_tolerance = FREE_ORIENTATION
    offset = pc.target_point_offset
    goal: dict[str, Any] = {
        "pose": {"position": position, "orientation": orientation},
        "link": pc.link_name or None,
        "position_tolerance": _region_tolerance(pc),
        "orientation_tolerance": orientation_tolerance if orientation_tolerance > 0 else 1e-3,
        "frame": pc.header.frame_id or "world",
    }
    if (offset.x, offset.y, offset.z) != (0.0, 0.0, 0.0):
        goal["ik_frame_offset"] = {"position": [offset.x, offset.y, offset.z], "orientation": [0.0, 0.0, 0.0, 1.0]}
    return goal


_REGION_TYPES = {SolidPrimitive.BOX: "box", SolidPrimitive.SPHERE: "sphere", SolidPrimitive.CYLINDER: "cylinder"}


def path_constraints_from_msg(constraints: Constraints) -> dict[str, Any] | None:
    """moveit_msgs/Constraints as path constraints in the core's JSON form (None when empty)."""
    if len(constraints.visibility_constraints):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN, "visibility constraints are not supported")
    data: dict[str, Any] = {
        "joints": [{"joint": jc.joint_name, "position": float(jc.position), "above": float(jc.tolerance_above),
                    "below": float(jc.tolerance_below)} for jc in constraints.joint_constraints],
        "orientation": [{"link": oc.link_name, "frame": oc.header.frame_id or "world",
                         "orientation": [oc.orientation.x, oc.orientation.y, oc.orientation.z, oc.orientation.w],
                         "tolerance": [float(oc.absolute_x_axis_tolerance), float(oc.absolute_y_axis_tolerance),
                                       float(oc.absolute_z_axis_tolerance)],
                         "parameterization": int(oc.parameterization)}
                        for oc in constraints.orientation_constraints],
        "position": [],
    }
    for pc in constraints.position_constraints:
        region = pc.constraint_region
        if len(region.meshes):
            raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                                  f"position constraint on {pc.link_name}: mesh regions are not supported")
        regions = []
        for primitive, pose in zip(region.primitives, region.primitive_poses):
            kind = _REGION_TYPES.get(int(primitive.type))
            if kind is None:
                raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                                      f"position constraint on {pc.link_name}: region type {primitive.type} is not "
                                      "supported (box, sphere, cylinder)")
            regions.append({"type": kind, "dimensions": [float(d) for d in primitive.dimensions],
                            "pose": pose_from_msg(pose)})
        offset = pc.target_point_offset
        data["position"].append({"link": pc.link_name, "frame": pc.header.frame_id or "world",
                                 "offset": [offset.x, offset.y, offset.z], "regions": regions})
    return data if any(data.values()) else None


def plan_params_from_request(request: Any) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(request parameters without the goal, the goals) from a moveit_msgs/MotionPlanRequest."""
    if len(request.goal_constraints) == 0:
        raise ConversionError(MoveItErrorCodes.INVALID_GOAL_CONSTRAINTS, "the request has no goal_constraints")
    goals = [goal_from_constraints(c) for c in request.goal_constraints]
    if len(request.trajectory_constraints.constraints):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN, "trajectory constraints are not supported")
    params: dict[str, Any] = {
        "group": request.group_name,
        "pipeline_id": request.pipeline_id,
        "planner_id": request.planner_id,
        "allowed_planning_time": float(request.allowed_planning_time),
        "num_planning_attempts": int(request.num_planning_attempts),
        "max_velocity_scaling_factor": float(request.max_velocity_scaling_factor),
        "max_acceleration_scaling_factor": float(request.max_acceleration_scaling_factor),
    }
    return _with_start_and_path(params, request), goals


def cartesian_params_from_request(request: Any) -> dict[str, Any]:
    """A compute_cartesian_path request in the core's form from moveit_msgs/GetCartesianPath."""
    params: dict[str, Any] = {
        "group": request.group_name,
        "waypoints": [pose_from_msg(p) for p in request.waypoints],
        "link": request.link_name or None,
        "frame": request.header.frame_id or "world",
        "eef_step": float(request.max_step) if request.max_step > 0 else 0.01,
        "jump_threshold": float(request.jump_threshold),
        "revolute_jump_threshold": float(request.revolute_jump_threshold),
        "prismatic_jump_threshold": float(request.prismatic_jump_threshold),
        "avoid_collisions": bool(request.avoid_collisions),
        "max_velocity_scaling_factor": float(request.max_velocity_scaling_factor),
        "max_acceleration_scaling_factor": float(request.max_acceleration_scaling_factor),
    }
    return _with_start_and_path(params, request)


def _with_start_and_path(params: dict[str, Any], request: Any) -> dict[str, Any]:
    """Add a request's start_state and path_constraints, when it has them."""
    path = path_constraints_from_msg(request.path_constraints)
    if path is not None:
        params["path_constraints"] = path
    start = robot_state_from_msg(request.start_state)
    if start is not None:
        params["start_state"] = start
    return params

