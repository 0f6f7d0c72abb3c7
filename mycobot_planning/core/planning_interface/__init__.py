"""MoveIt's planning_interface: motion plan requests and responses with their error codes
(planning_interface), planning contexts for concurrent plans (planning_contexts) and the
pipeline that dispatches a request to a planner (planning_pipeline).

The pipeline is not re-exported here: it imports the planners, which import this package's
request and response types (``from mycobot_planning.core import PlanningPipeline``, or
``core.planning_interface.planning_pipeline``)."""
from .planning_contexts import PlanningContextPool
from .planning_interface import JointGoal, MotionPlanRequest, MotionPlanResponse, NamedGoal, PlanningFailure, PoseGoal

__all__ = ["JointGoal", "MotionPlanRequest", "MotionPlanResponse", "NamedGoal", "PlanningContextPool",
           "PlanningFailure", "PoseGoal"]
