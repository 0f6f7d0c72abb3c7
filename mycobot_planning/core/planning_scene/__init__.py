"""The planning scene (moveit_core/planning_scene): world objects, attached objects, the allowed
collision matrix and validity checks; planning_scene_monitor keeps move_group's current scene
and applies diffs to it (moveit_ros/planning_scene_monitor)."""
from .planning_scene import CollisionReport, Contact, DistanceReport, PlanningScene
from .planning_scene_monitor import PlanningSceneMonitor

__all__ = ["CollisionReport", "Contact", "DistanceReport", "PlanningScene", "PlanningSceneMonitor"]
