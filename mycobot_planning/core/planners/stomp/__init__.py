"""MoveIt's STOMP planner (pipeline_id "stomp"): stochastic trajectory optimisation."""
from .stomp import (
    DEFAULT_PARAMS,
    PLANNER_ID,
    STOMP_PIPELINE_ID,
    StompParams,
    StompPlanner,
    plan_stomp,
)

__all__ = ["DEFAULT_PARAMS", "PLANNER_ID", "STOMP_PIPELINE_ID", "StompParams", "StompPlanner", "plan_stomp"]
