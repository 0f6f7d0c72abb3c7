"""A setup assistant: from a URDF (or xacro) to a robot configuration directory every part loads.

MoveIt users get a working config from MoveIt Setup Assistant; this is its command-line
counterpart (`python -m mycobot_planning.setup_assistant`). It writes the SRDF with the
self-collision matrix (core.collision_detection.collision_matrix), planning groups, named states and end effectors,
plus joint_limits.yaml, kinematics.yaml, ompl_planning.yaml, moveit_controllers.yaml and
ros2_controllers.yaml, and a manifest (core.robot_model.robot_config). No rclpy here: it is a plain tool.
"""
from .assistant import SetupReport, build_config
from .default_groups import GroupSpec, default_groups, parse_end_effector

__all__ = ["SetupReport", "build_config", "GroupSpec", "default_groups", "parse_end_effector"]
