"""``moveit.planning``: MoveItPy, PlanningComponent, the plan request parameters and the planning
scene monitor (moveit_py's names and signatures; docs/moveit_py.md)."""
from ._moveit_cpp import (
    LockedPlanningSceneContextManagerRO,
    LockedPlanningSceneContextManagerRW,
    MoveItPy,
    PlanningSceneMonitor,
)
from ._planning_component import MultiPipelinePlanRequestParameters, PlanRequestParameters, PlanningComponent

__all__ = ["LockedPlanningSceneContextManagerRO", "LockedPlanningSceneContextManagerRW", "MoveItPy",
           "MultiPipelinePlanRequestParameters", "PlanRequestParameters", "PlanningComponent", "PlanningSceneMonitor"]
