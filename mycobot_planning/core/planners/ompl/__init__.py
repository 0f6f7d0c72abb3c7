"""MoveIt's ompl_interface on the ompl PyPI wheel: the planner registry (planners), the
ompl_planning.yaml config and planner_id lookup (config), joint-space solving (solve) and the
planner manager that turns a MotionPlanRequest into all that (planner_manager). docs/ompl.md
records what the wheel forces on this code."""
from .config import (
    GroupConfig,
    OmplConfig,
    PlannerConfig,
    ResolvedPlanner,
    load_ompl_config,
    parse_projection_evaluator,
    resolve_planner_id,
)
from .planner_manager import OmplPlanner
from .planners import (
    UNAVAILABLE_MOVEIT_PLANNERS,
    OmplConfigError,
    available_planners,
    canonical_planner_type,
    set_ompl_log_level,
)
from .solve import OmplResult, plan_joint_space

__all__ = [
    "GroupConfig",
    "OmplConfig",
    "OmplConfigError",
    "OmplPlanner",
    "OmplResult",
    "PlannerConfig",
    "ResolvedPlanner",
    "UNAVAILABLE_MOVEIT_PLANNERS",
    "available_planners",
    "canonical_planner_type",
    "load_ompl_config",
    "parse_projection_evaluator",
    "plan_joint_space",
    "resolve_planner_id",
    "set_ompl_log_level",
]
