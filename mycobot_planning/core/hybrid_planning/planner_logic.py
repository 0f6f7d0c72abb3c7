"""The hybrid planning manager's planner logic (MoveIt's PlannerLogicInterface plugins): what the
manager does on each event of a hybrid planning run.

* ``SinglePlanExecution``: request -> global planner; global planning succeeded -> local planner
  (once); local planner succeeded -> the run succeeds; global or local planner aborted (or
  rejected the goal) -> the run fails with PLANNING_FAILED.
* ``ReplanInvalidatedTrajectory``: the same, and the local planner's feedback "Collision ahead"
  or "Local planner is stuck" sends a new global planning request (a replan from the current
  state) while the local planner holds the arm.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from interfaces_py.msgs import MoveItErrorCode

__all__ = ["PLANNER_LOGIC_PLUGINS", "HybridPlanningAction", "HybridPlanningEvent", "LocalFeedback", "Reaction",
           "ReplanInvalidatedTrajectory", "SinglePlanExecution", "planner_logic"]


class HybridPlanningEvent(Enum):
    """MoveIt's hybrid_planning_events.hpp."""

    HYBRID_PLANNING_REQUEST_RECEIVED = "HYBRID_PLANNING_REQUEST_RECEIVED"
    GLOBAL_PLANNING_ACTION_SUCCESSFUL = "GLOBAL_PLANNING_ACTION_SUCCESSFUL"
    GLOBAL_PLANNING_ACTION_ABORTED = "GLOBAL_PLANNING_ACTION_ABORTED"
    GLOBAL_PLANNING_ACTION_CANCELED = "GLOBAL_PLANNING_ACTION_CANCELED"
    GLOBAL_PLANNING_ACTION_REJECTED = "GLOBAL_PLANNING_ACTION_REJECTED"
    GLOBAL_SOLUTION_AVAILABLE = "GLOBAL_SOLUTION_AVAILABLE"
    LOCAL_PLANNING_ACTION_SUCCESSFUL = "LOCAL_PLANNING_ACTION_SUCCESSFUL"
    LOCAL_PLANNING_ACTION_ABORTED = "LOCAL_PLANNING_ACTION_ABORTED"
    LOCAL_PLANNING_ACTION_CANCELED = "LOCAL_PLANNING_ACTION_CANCELED"
    LOCAL_PLANNING_ACTION_REJECTED = "LOCAL_PLANNING_ACTION_REJECTED"
    UNDEFINED = "UNDEFINED"


class HybridPlanningAction(Enum):
    DO_NOTHING = "DO_NOTHING"
    RETURN_HP_SUCCESS = "RETURN_HP_SUCCESS"
    RETURN_HP_FAILURE = "RETURN_HP_FAILURE"
    SEND_GLOBAL_SOLVER_REQUEST = "SEND_GLOBAL_SOLVER_REQUEST"
    SEND_LOCAL_SOLVER_REQUEST = "SEND_LOCAL_SOLVER_REQUEST"


class LocalFeedback:
    """The local planner's feedback strings (MoveIt's LocalFeedbackEnum)."""

    COLLISION_AHEAD = "Collision ahead"
    LOCAL_PLANNER_STUCK = "Local planner is stuck"


@dataclass(frozen=True)
class Reaction:
    """What the manager does next, with the run's error code and message for a RETURN_HP_* action."""

    action: HybridPlanningAction
    error_code: int = MoveItErrorCode.SUCCESS
    message: str = ""


_NOTHING = Reaction(HybridPlanningAction.DO_NOTHING)


class SinglePlanExecution:
    """Plan once, follow the plan with the local planner, answer its outcome."""

    name = "SinglePlanExecution"

    def __init__(self) -> None:
        self.local_planner_started = False

    def react(self, event: HybridPlanningEvent) -> Reaction:
        E, A = HybridPlanningEvent, HybridPlanningAction
        if event is E.HYBRID_PLANNING_REQUEST_RECEIVED:
            self.local_planner_started = False
            return Reaction(A.SEND_GLOBAL_SOLVER_REQUEST)
        if event is E.GLOBAL_SOLUTION_AVAILABLE:
            return _NOTHING  # the local planner takes it from the global_trajectory topic
        if event is E.GLOBAL_PLANNING_ACTION_SUCCESSFUL:
            if self.local_planner_started:  # a replan: the running local planner follows the new trajectory
                return _NOTHING
            self.local_planner_started = True
            return Reaction(A.SEND_LOCAL_SOLVER_REQUEST)
        if event in (E.GLOBAL_PLANNING_ACTION_ABORTED, E.GLOBAL_PLANNING_ACTION_REJECTED):
            return Reaction(A.RETURN_HP_FAILURE, MoveItErrorCode.PLANNING_FAILED,
                            "Global planner failed to find a solution")
        if event is E.LOCAL_PLANNING_ACTION_SUCCESSFUL:
            return Reaction(A.RETURN_HP_SUCCESS)
        if event in (E.LOCAL_PLANNING_ACTION_ABORTED, E.LOCAL_PLANNING_ACTION_REJECTED):
            return Reaction(A.RETURN_HP_FAILURE, MoveItErrorCode.PLANNING_FAILED,
                            "Local planner failed to find a solution")
        if event in (E.GLOBAL_PLANNING_ACTION_CANCELED, E.LOCAL_PLANNING_ACTION_CANCELED):
            return Reaction(A.RETURN_HP_FAILURE, MoveItErrorCode.PREEMPTED,
                            f"{'Global' if event is E.GLOBAL_PLANNING_ACTION_CANCELED else 'Local'} planning "
                            "was canceled")
        return Reaction(A.DO_NOTHING, MoveItErrorCode.FAILURE,
                        f"'Single-Plan-Execution' plugin cannot handle this event ({event.value}).")

    def react_to_feedback(self, feedback: str) -> Reaction:
        """The local planner's feedback: nothing to do for a single plan."""
        return Reaction(HybridPlanningAction.DO_NOTHING, MoveItErrorCode.FAILURE,
                        f"'{self.name}' plugin cannot handle this event ({feedback}).")


class ReplanInvalidatedTrajectory(SinglePlanExecution):
    """SinglePlanExecution that replans when the local planner reports the plan invalid or stuck."""

    name = "ReplanInvalidatedTrajectory"

    def react_to_feedback(self, feedback: str) -> Reaction:
        if feedback in (LocalFeedback.COLLISION_AHEAD, LocalFeedback.LOCAL_PLANNER_STUCK):
            return Reaction(HybridPlanningAction.SEND_GLOBAL_SOLVER_REQUEST)
        return super().react_to_feedback(feedback)


#: planner_logic_plugin_name values accepted: MoveIt's plugin names (both spellings its sources
#: use) and the bare class names
PLANNER_LOGIC_PLUGINS: dict[str, type[SinglePlanExecution]] = {}
for _cls in (SinglePlanExecution, ReplanInvalidatedTrajectory):
    for _prefix in ("moveit::hybrid_planning/", "moveit_hybrid_planning/", ""):
        PLANNER_LOGIC_PLUGINS[_prefix + _cls.name] = _cls


def planner_logic(plugin_name: str) -> SinglePlanExecution:
    """A fresh planner logic for one run (ValueError naming the known plugins)."""
    cls = PLANNER_LOGIC_PLUGINS.get(plugin_name.strip())
    if cls is None:
        raise ValueError(f"unknown planner logic plugin '{plugin_name}'; known: "
                         + ", ".join(n for n in PLANNER_LOGIC_PLUGINS if n.startswith("moveit::")))
    return cls()
