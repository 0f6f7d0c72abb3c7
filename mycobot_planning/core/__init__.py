"""ROS-free planning core: robot model, state, kinematics, planning scene, planners, timing.

Import from here in user code: ``from mycobot_planning.core import RobotModel, RobotState``.
Nothing in this package imports rclpy.
"""
from .errors import KinematicsError, PlanningError, RobotModelError, SceneError, StateError
from .robot_model.robot_model import EndEffector, JointInfo, JointModelGroup, RobotModel
from .robot_state.robot_state import RobotState
from .collision_detection.acm import AllowedCollisionMatrix
from .planning_scene.planning_scene import CollisionReport, Contact, DistanceReport, PlanningScene
from .kinematics.ik_solver import IKSolver, solve_ik
from .robot_trajectory.robot_trajectory import TimedTrajectory
from .trajectory_processing import retime, time_parameterize
from .planning_interface.planning_interface import JointGoal, MotionPlanRequest, MotionPlanResponse, NamedGoal, PoseGoal
from .planning_interface.planning_pipeline import PlanningPipeline
from .planners.cartesian.cartesian_path import compute_cartesian_path
from .planners.cartesian.relative_motion import plan_relative_motion
from .trajectory_processing.trajectory_validator import ValidationReport, validate_trajectory

__all__ = [
    "IKSolver",
    "JointGoal",
    "MotionPlanRequest",
    "MotionPlanResponse",
    "NamedGoal",
    "PlanningPipeline",
    "PoseGoal",
    "TimedTrajectory",
    "ValidationReport",
    "compute_cartesian_path",
    "plan_relative_motion",
    "retime",
    "solve_ik",
    "time_parameterize",
    "validate_trajectory",
    "AllowedCollisionMatrix",
    "CollisionReport",
    "Contact",
    "DistanceReport",
    "PlanningScene",
    "EndEffector",
    "JointInfo",
    "JointModelGroup",
    "KinematicsError",
    "PlanningError",
    "RobotModel",
    "RobotModelError",
    "RobotState",
    "SceneError",
    "StateError",
]
