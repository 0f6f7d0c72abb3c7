"""Where OmplPlanner used to live: it is core.ompl_interface.planner_manager now."""
from .ompl_interface.planner_manager import OmplPlanner

__all__ = ["OmplPlanner"]
