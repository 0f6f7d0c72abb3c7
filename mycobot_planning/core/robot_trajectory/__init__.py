"""The robot trajectory (moveit_core/robot_trajectory): timed joint waypoints, their
trajectory_msgs form, and their waypoints made dense (max_waypoint_distance)."""
from .robot_trajectory import (DEFAULT_MAX_WAYPOINT_DISTANCE, TimedTrajectory, densify_joint_trajectory,
                               joint_trajectory_to_timed, limit_waypoint_distance, timed_to_joint_trajectory)

__all__ = ["DEFAULT_MAX_WAYPOINT_DISTANCE", "TimedTrajectory", "densify_joint_trajectory", "joint_trajectory_to_timed",
           "limit_waypoint_distance", "timed_to_joint_trajectory"]
