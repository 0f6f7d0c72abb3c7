"""moveit_msgs <-> the capabilities' typed calls: what the move_group face reads from a request
and writes into a response, without going through the JSON face's dicts.

Goals become core JointGoal / PoseGoal objects, start states interfaces_py RobotState messages,
trajectories go straight from the typed JointTrajectory into trajectory_msgs (one array copy per
point). Path constraints keep the core's constraint description (kinematic_constraints reads it).
"""
from __future__ import annotations

import math
from array import array
from typing import Any, Mapping

import numpy as np

from moveit_msgs.msg import Constraints, MoveItErrorCodes, RobotState as RobotStateRos, RobotTrajectory as RobotTrajectoryRos

from interfaces_py.moveit_conversions import path_constraints_from_msg, robot_state_from_msg
from interfaces_py.msgs import (
    JointTrajectory,
    JointTrajectoryPoint as JointTrajectoryPointMsg,
    MessageError,
    RobotState as RobotStateMsg,
)
from interfaces_py.pose_conversion import PoseError, pose_matrix
from interfaces_py.ros_conversions import joint_trajectory_to_msg
from interfaces_py.ros_message_reading import ConversionError
from mycobot_planning.capabilities.cartesian_path import CartesianPathRequest
from mycobot_planning.capabilities.move_group_context import RequestError, check_tolerance
from mycobot_planning.core.planning_interface.planning_interface import Goal, JointGoal, MotionPlanRequest, PoseGoal

#: rad: an orientation constraint this loose on every axis leaves the orientation free
FREE_ORIENTATION = math.pi
#: m: the position tolerance of a region made of meshes only (their extent is not read)
MESH_REGION_TOLERANCE = 1e-3

__all__ = ["cartesian_request_from_msg", "goal_from_constraints", "joint_trajectory_from_ros",
           "motion_plan_request_from_msg", "pose_from_ros", "robot_state_from_ros", "robot_state_to_ros",
           "robot_trajectory_to_ros"]


def robot_state_from_ros(msg: RobotStateRos) -> RobotStateMsg | None:
    """None for an empty diff start state ("start from the current state", MoveIt's default)."""
    data = robot_state_from_msg(msg)
    if data is None:
        return None
    try:
        return RobotStateMsg.from_dict(data)
    except MessageError as exc:
        raise ConversionError(MoveItErrorCodes.INVALID_ROBOT_STATE, f"invalid robot state: {exc}") from None


def robot_state_to_ros(positions: Mapping[str, float], stamp: Any = None) -> RobotStateRos:
    msg = RobotStateRos()
    msg.joint_state.name = list(positions)
    msg.joint_state.position = array("d", positions.values())
    if stamp is not None:
        msg.joint_state.header.stamp = stamp
    return msg


def robot_trajectory_to_ros(trajectory: JointTrajectory, frame_id: str) -> RobotTrajectoryRos:
    msg = RobotTrajectoryRos()
    msg.joint_trajectory = joint_trajectory_to_msg(trajectory)
    msg.joint_trajectory.header.frame_id = frame_id
    return msg


#: how many dimensions each shape_msgs/SolidPrimitive type has (BOX 1, SPHERE 2, CYLINDER 3, CONE 4)
_PRIMITIVE_DIMENSIONS = {1: 3, 2: 1, 3: 2, 4: 2}


def _tolerance(value: Any, what: str) -> float:
    """A goal tolerance through the capabilities' one check (finite, >= 0), as a ConversionError."""
    try:
        return check_tolerance(float(value), what)
    except RequestError as exc:
        raise ConversionError(exc.moveit_code, exc.message) from None


def _region_tolerance(constraint: Any) -> float:
    """A position constraint region's tolerance: a sphere's radius, a box's smallest half extent
    (the smallest over its primitives). A region must have volume: at least one primitive or
    mesh, as many poses as primitives (and meshes), every primitive's dimensions complete,
    finite and > 0 (ConversionError otherwise: never a point or a 1 mm ball in its place)."""
    bad = MoveItErrorCodes.INVALID_GOAL_CONSTRAINTS
    region = constraint.constraint_region
    if len(region.primitives) != len(region.primitive_poses):
        raise ConversionError(bad, f"position constraint: {len(region.primitives)} primitives but "
                                   f"{len(region.primitive_poses)} primitive poses")
    if len(region.meshes) != len(region.mesh_poses):
        raise ConversionError(bad, f"position constraint: {len(region.meshes)} meshes but "
                                   f"{len(region.mesh_poses)} mesh poses")
    if not len(region.primitives) and not len(region.meshes):
        raise ConversionError(bad, "position constraint: constraint_region has no primitive (a region needs a volume)")
    tolerances = []
    for k, primitive in enumerate(region.primitives):
        dims = [float(d) for d in primitive.dimensions]
        expected = _PRIMITIVE_DIMENSIONS.get(int(primitive.type))
        if expected is None:
            raise ConversionError(bad, f"position constraint: primitive {k} has unknown type {primitive.type}")
        if len(dims) != expected or not all(math.isfinite(d) and d > 0 for d in dims):
            raise ConversionError(bad, f"position constraint: primitive {k} has no volume: {expected} finite "
                                       f"dimensions > 0 expected, got {dims}")
        if primitive.type == primitive.SPHERE:
            tolerances.append(dims[0])
        elif primitive.type == primitive.BOX:
            tolerances.append(min(dims) / 2)
        else:  # CYLINDER, CONE: height, radius
            tolerances.append(min(dims[0] / 2, dims[1]))
    return min(tolerances) if tolerances else MESH_REGION_TOLERANCE


def goal_from_constraints(constraints: Constraints) -> tuple[Goal, str]:
    """One typed goal and the frame its pose is in, from one moveit_msgs/Constraints: joint
    constraints -> a JointGoal; a position constraint (with or without an orientation constraint
    on the same link) -> a PoseGoal (a free orientation without an orientation constraint)."""
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
        values: dict[str, float] = {}
        for jc in joints:
            position = float(jc.position)
            if jc.joint_name in values and values[jc.joint_name] != position:
                raise ConversionError(bad, f"joint '{jc.joint_name}' is constrained twice, to {values[jc.joint_name]:g} "
                                           f"and {position:g}")
            values[jc.joint_name] = position
        tolerance = max(max(_tolerance(jc.tolerance_above, f"tolerance_above of joint '{jc.joint_name}'"),
                            _tolerance(jc.tolerance_below, f"tolerance_below of joint '{jc.joint_name}'"))
                        for jc in joints)
        # 0 (both tolerances left unset) reads as "exact": the planners' own 1e-4 rad
        return JointGoal(values, tolerance if tolerance > 0 else 1e-4), "world"
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
    region_tolerance = _region_tolerance(pc)
    centre = region.primitive_poses[0] if len(region.primitive_poses) else region.mesh_poses[0]
    position = [centre.position.x, centre.position.y, centre.position.z]
    if oc is not None:
        q = oc.orientation
        quaternion = [q.x, q.y, q.z, q.w]
        orientation_tolerance = max(_tolerance(getattr(oc, f"absolute_{axis}_axis_tolerance"),
                                               f"orientation constraint absolute_{axis}_axis_tolerance")
                                    for axis in "xyz")
        if oc.header.frame_id and pc.header.frame_id and oc.header.frame_id != pc.header.frame_id:
            raise ConversionError(bad, f"position constraint in '{pc.header.frame_id}' and orientation constraint "
                                       f"in '{oc.header.frame_id}': give both in one frame")
    else:
        quaternion = [0.0, 0.0, 0.0, 1.0]
        orientation_tolerance = FREE_ORIENTATION
    offset = pc.target_point_offset
    try:
        pose = pose_matrix(position + quaternion, "goal pose")
        ik_offset = None
        if (offset.x, offset.y, offset.z) != (0.0, 0.0, 0.0):
            ik_offset = pose_matrix([offset.x, offset.y, offset.z, 0.0, 0.0, 0.0, 1.0], "ik_frame_offset")
    except PoseError as exc:
        raise ConversionError(bad, f"invalid {exc}") from None
    goal = PoseGoal(pose, pc.link_name or None, ik_offset, region_tolerance,
                    orientation_tolerance if orientation_tolerance > 0 else 1e-3)
    return goal, pc.header.frame_id or "world"


def motion_plan_request_from_msg(msg: Any) -> tuple[list[tuple[MotionPlanRequest, str]], RobotStateMsg | None, Any]:
    """A moveit_msgs/MotionPlanRequest as the plan capability's arguments: one (request, goal
    frame) per goal_constraints entry (MoveIt: "any of them"), the start state, the path
    constraints. What the message leaves at 0 / "" the capability fills with the defaults."""
    if len(msg.goal_constraints) == 0:
        raise ConversionError(MoveItErrorCodes.INVALID_GOAL_CONSTRAINTS, "the request has no goal_constraints")
    if len(msg.trajectory_constraints.constraints):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN, "trajectory constraints are not supported")
    requests = []
    for constraints in msg.goal_constraints:
        goal, frame = goal_from_constraints(constraints)
        requests.append((MotionPlanRequest(
            group=msg.group_name, goal=goal, pipeline_id=msg.pipeline_id, planner_id=msg.planner_id,
            allowed_planning_time=float(msg.allowed_planning_time),
            num_planning_attempts=int(msg.num_planning_attempts),
            max_velocity_scaling_factor=float(msg.max_velocity_scaling_factor),
            max_acceleration_scaling_factor=float(msg.max_acceleration_scaling_factor)), frame))
    return requests, robot_state_from_ros(msg.start_state), path_constraints_from_msg(msg.path_constraints)


def pose_from_ros(msg: Any, what: str, code: int = MoveItErrorCodes.INVALID_GOAL_CONSTRAINTS) -> np.ndarray:
    """A geometry_msgs/Pose as a 4x4 transform (ConversionError with ``code`` when malformed)."""
    try:
        return pose_matrix(msg, what)
    except PoseError as exc:
        raise ConversionError(code, f"invalid {exc}") from None


def joint_trajectory_from_ros(msg: RobotTrajectoryRos) -> tuple[JointTrajectory, str]:
    """A moveit_msgs/RobotTrajectory's joint trajectory, checked (ConversionError when not)."""
    if len(msg.multi_dof_joint_trajectory.points):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                              "trajectory: multi-DOF trajectories are not supported (the robot's joints are "
                              "single-DOF)")
    jt = msg.joint_trajectory
    if not len(jt.points):
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN, "trajectory: joint_trajectory has no points")
    try:
        return JointTrajectory(list(jt.joint_names), [JointTrajectoryPointMsg(
            list(p.positions), list(p.velocities), list(p.accelerations),
            p.time_from_start.sec + p.time_from_start.nanosec * 1e-9) for p in jt.points]), ""
    except MessageError as exc:
        raise ConversionError(MoveItErrorCodes.INVALID_MOTION_PLAN, f"trajectory: {exc}") from None


def cartesian_request_from_msg(msg: Any) -> CartesianPathRequest:
    """A moveit_msgs/GetCartesianPath request as the Cartesian path capability's request."""
    return CartesianPathRequest(
        group=msg.group_name,
        waypoints=[pose_from_ros(p, f"waypoint {k}", MoveItErrorCodes.INVALID_MOTION_PLAN)
                   for k, p in enumerate(msg.waypoints)],
        frame=msg.header.frame_id or "world",
        link=msg.link_name,
        eef_step=float(msg.max_step),  # <= 0 or NaN: FAILURE, as MoveIt answers
        jump_threshold=float(msg.jump_threshold),
        revolute_jump_threshold=float(msg.revolute_jump_threshold),
        prismatic_jump_threshold=float(msg.prismatic_jump_threshold),
        avoid_collisions=bool(msg.avoid_collisions),
        max_velocity_scaling_factor=float(msg.max_velocity_scaling_factor),
        max_acceleration_scaling_factor=float(msg.max_acceleration_scaling_factor),
        start_state=robot_state_from_ros(msg.start_state),
        path_constraints=path_constraints_from_msg(msg.path_constraints),
    )
