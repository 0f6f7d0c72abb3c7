"""The robot trajectory (moveit_core/robot_trajectory): timed joint waypoints and their
trajectory_msgs form."""
from .robot_trajectory import TimedTrajectory, joint_trajectory_to_timed, timed_to_joint_trajectory

__all__ = ["TimedTrajectory", "joint_trajectory_to_timed", "timed_to_joint_trajectory"]
