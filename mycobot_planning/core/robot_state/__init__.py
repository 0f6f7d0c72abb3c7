"""The robot state (moveit_core/robot_state): joint values of a model, group views, forward
kinematics and Jacobians; tf_tree turns a state into the transforms robot_state_publisher sends."""
from .robot_state import RobotState
from .tf_tree import joint_transforms

__all__ = ["RobotState", "joint_transforms"]
