"""Hybrid planning's ROS-free logic (MoveIt's moveit_hybrid_planning plugins): the planner logic
state machines of the manager and the local planner's reference sampling, forwarding, collision
hold and stuck detection. The ROS components: mycobot_planning.ros.hybrid_planning;
docs/hybrid_planning.md."""
from .local_planner import (
    STUCK_ITERATIONS_THRESHOLD,
    STUCK_THRESHOLD_RAD,
    WAYPOINT_RADIAN_TOLERANCE,
    ForwardTrajectory,
    LocalCommand,
    SimpleSampler,
    StuckDetector,
)
from .planner_logic import (
    PLANNER_LOGIC_PLUGINS,
    HybridPlanningAction,
    HybridPlanningEvent,
    LocalFeedback,
    Reaction,
    ReplanInvalidatedTrajectory,
    SinglePlanExecution,
    planner_logic,
)

__all__ = [
    "PLANNER_LOGIC_PLUGINS",
    "STUCK_ITERATIONS_THRESHOLD",
    "STUCK_THRESHOLD_RAD",
    "WAYPOINT_RADIAN_TOLERANCE",
    "ForwardTrajectory",
    "HybridPlanningAction",
    "HybridPlanningEvent",
    "LocalCommand",
    "LocalFeedback",
    "Reaction",
    "ReplanInvalidatedTrajectory",
    "SimpleSampler",
    "SinglePlanExecution",
    "StuckDetector",
    "planner_logic",
]
