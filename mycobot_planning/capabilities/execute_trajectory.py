"""move_group's execute trajectory capability (MoveIt: MoveGroupExecuteTrajectoryAction,
/execute_trajectory): a trajectory, or the last plan, through the trajectory execution manager."""
from __future__ import annotations

from typing import Sequence

from interfaces_py.msgs import JointTrajectory, MoveItErrorCode

from ..core.trajectory_execution import ExecutionResult
from .move_group_context import MoveGroupContext

__all__ = ["execute_trajectory"]


def execute_trajectory(ctx: MoveGroupContext, trajectory: JointTrajectory | None = None,
                       controllers: Sequence[str] | None = None, description: str = "") -> ExecutionResult:
    """Execute ``trajectory`` (None: the last plan) on ``controllers`` (None: those that drive
    its joints); blocks until it ends. ``description`` names it in logs and the execution status
    ("trajectory" when empty). Never raises for bad input: the result says why."""
    if trajectory is None:
        last = ctx.last_plan
        if last is None:
            ctx.log("warning", f"execute refused: no plan to execute: {ctx.last_plan_problem}")
            return ExecutionResult(MoveItErrorCode(MoveItErrorCode.INVALID_MOTION_PLAN,
                                                   f"no plan to execute: {ctx.last_plan_problem}", "planning_server"))
        trajectory, description = last[0], f"last plan of '{last[1]}'"
    else:
        description = description or "trajectory"
    return ctx.executor.execute(trajectory, list(controllers) if controllers else None, description)
