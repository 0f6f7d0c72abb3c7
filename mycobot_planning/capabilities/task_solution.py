"""MTC's execute task solution capability (ExecuteTaskSolutionCapability,
/execute_task_solution): each step's trajectory, then its scene diff, applied to the live scene."""
from __future__ import annotations

from typing import Sequence

from ..core.trajectory_execution import SolutionResult, SolutionStep
from .move_group_context import MoveGroupContext

__all__ = ["execute_task_solution"]


def execute_task_solution(ctx: MoveGroupContext, steps: Sequence[SolutionStep]) -> SolutionResult:
    """Execute parsed solution steps (core.trajectory_execution.parse_task_solution); blocks.
    A scene diff whose collision matrix names something that is neither a link, a group nor an
    object of the scene or of an earlier diff is logged, not refused: MTC's solutions carry the
    task's whole matrix, which names objects the task knew even when they are gone (mtc_node
    with spawn_table false removes the table its stages still name), and move_group applies
    them as they are."""
    added: set[str] = set()
    for k, step in enumerate(steps):
        for which, diff in (("scene_diff_before", step.scene_diff_before), ("scene_diff_after", step.scene_diff_after)):
            if diff is None:
                continue
            unknown = ctx.unknown_acm_names(diff, added)
            if unknown:
                message = (f"step {k} ('{step.name}'): {which}'s allowed collision matrix names {unknown}, which are "
                           f"neither links of robot '{ctx.model.name}' nor collision objects")
                ctx.log("warning", f"task solution: {message}; applied as it is, as move_group does")
            added |= {o.id for o in diff.world.collision_objects}
            added |= {a.object.id for a in diff.robot_state.attached_collision_objects}
    return ctx.executor.execute_solution(steps, ctx.apply_diff_live, ctx.scene_copy())
