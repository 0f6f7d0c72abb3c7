"""move_group's capabilities, between the planning core and the nodes: the monitored scene and
current state, plan, execute, Cartesian paths, IK/FK, state validity, task-solution execution.

Both faces of the planning_server are thin translations into these calls: the JSON /
std_srvs face (ros/move_group/planning_server.py) and MoveIt's moveit_msgs face (ros/move_group/move_group.py,
through interfaces_py.moveit_conversions). No rclpy here.
"""
from .move_group_capabilities import MoveGroupCapabilities, PlanningDefaults, RequestError

__all__ = ["MoveGroupCapabilities", "PlanningDefaults", "RequestError"]
