"""ROS-free planning core: robot model, state, kinematics, planning scene, planners, timing.

Import from here in user code: ``from mycobot_planning.core import RobotModel, RobotState``.
Nothing in this package imports rclpy.
"""
from .errors import KinematicsError, PlanningError, RobotModelError, SceneError, StateError
from .robot_model import EndEffector, JointInfo, JointModelGroup, RobotModel
from .robot_state import RobotState
from .acm import AllowedCollisionMatrix
from .planning_scene import CollisionReport, Contact, DistanceReport, PlanningScene

__all__ = [
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
