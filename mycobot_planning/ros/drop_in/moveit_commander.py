"""``moveit_commander``'s PlanningSceneInterface, for scripts that still import it.

moveit_commander is ROS 1's Python API; MTC's ros2-branch pickplace.py still imports its
PlanningSceneInterface. Ours (interfaces_py.clients.PlanningSceneInterface) takes its arguments
(``ns``, ``synchronous``, ``service_timeout``) and its calls (``add_box`` with a PoseStamped,
``remove_world_object``, ``attach_object``, ``get_known_object_names``, ...) against the
planning_server's scene.
"""
from interfaces_py.clients import PlanningSceneInterface

__all__ = ["PlanningSceneInterface"]
