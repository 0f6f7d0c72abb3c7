"""move_group's move action capability (MoveIt: MoveGroupMoveAction, /move_action): plan, then
execute the plan when planning succeeded and the request is not plan-only."""
from __future__ import annotations

from typing import Any, Callable, Sequence

from interfaces_py.msgs import MoveItErrorCode, RobotState as RobotStateMsg

from ..core.planning_interface.planning_interface import MotionPlanRequest
from ..core.trajectory_execution import ExecutionResult
from .execute_trajectory import execute_trajectory
from .move_group_context import SOURCE, MoveGroupContext
from .plan import PlanResult, plan_any

__all__ = ["plan_and_execute"]


def plan_and_execute(ctx: MoveGroupContext, requests: Sequence[tuple[MotionPlanRequest, str]],
                     start_state: RobotStateMsg | None = None, path_constraints: Any = None, display: bool = True,
                     plan_only: bool = False, before_execution: Callable[[PlanResult], bool] | None = None
                     ) -> tuple[PlanResult | None, ExecutionResult | None]:
    """(plan, execution) of (request, goal frame) pairs as plan_any reads them. The plan is None
    when the request is refused because another execution runs (the execution result says so);
    the execution is None when planning failed, ``plan_only``, or ``before_execution`` (told
    the plan) returned False."""
    if not plan_only and ctx.executor.executing:
        status = ctx.executor.status()
        return None, ExecutionResult(MoveItErrorCode(
            MoveItErrorCode.FAILURE, f"refused: another execution ({status['description']}) is in progress; stop it "
                                     "first or wait for it to finish", SOURCE))
    planned = plan_any(ctx, requests, start_state, path_constraints, display)
    if planned.trajectory is None or plan_only or (before_execution is not None and not before_execution(planned)):
        return planned, None
    return planned, execute_trajectory(ctx, planned.trajectory, None, f"plan of '{planned.group}'")
