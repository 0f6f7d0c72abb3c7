"""MoveIt's CHOMP planner (pipeline_id "chomp"): covariant gradient descent on a smoothness and an obstacle cost."""
from .chomp import (
    CHOMP_PIPELINE_ID,
    DEFAULT_PARAMS,
    INITIALIZATION_METHODS,
    PLANNER_ID,
    ChompParams,
    ChompPlanner,
    plan_chomp,
)

__all__ = ["CHOMP_PIPELINE_ID", "ChompParams", "ChompPlanner", "DEFAULT_PARAMS", "INITIALIZATION_METHODS",
           "PLANNER_ID", "plan_chomp"]
