"""MTC's execute task solution capability (ExecuteTaskSolutionCapability,
/execute_task_solution): each step's trajectory, then its scene diff, applied to the live scene."""
from __future__ import annotations

from typing import Sequence

from ..core.trajectory_execution import SolutionResult, SolutionStep
from .move_group_context import MoveGroupContext

__all__ = ["execute_task_solution"]


def execute_task_solution(ctx: MoveGroupContext, steps: Sequence[SolutionStep]) -> SolutionResult:
    """Execute parsed solution steps (core.trajectory_execution.parse_task_solution); blocks."""
    return ctx.executor.execute_solution(steps, ctx.apply_diff_live, ctx.scene_copy())
