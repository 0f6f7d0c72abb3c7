"""MTC's execute task solution capability (ExecuteTaskSolutionCapability,
/execute_task_solution): each step's trajectory, then its scene diff, applied to the live scene."""
from __future__ import annotations

from typing import Sequence

from interfaces_py.msgs import MoveItErrorCode

from ..core.trajectory_execution import SolutionResult, SolutionStep
from .move_group_context import SOURCE, MoveGroupContext, RequestError

__all__ = ["execute_task_solution"]


def execute_task_solution(ctx: MoveGroupContext, steps: Sequence[SolutionStep]) -> SolutionResult:
    """Execute parsed solution steps (core.trajectory_execution.parse_task_solution); blocks.
    A scene diff whose collision matrix names something that is neither a link, a group nor an
    object of the scene or of an earlier diff is logged, not refused: MTC's solutions carry the
    task's whole matrix, which names objects the task knew even when they are gone (mtc_node
    with spawn_table false removes the table its stages still name), and move_group applies
    them as they are. Every other problem of a diff (objects, padding, scale, a robot state
    outside the limits or naming unknown joints) refuses the whole solution before anything
    moves: the diffs are tried in order on a copy of the scene first."""
    added: set[str] = set()
    trial = ctx.scene_copy()
    for k, step in enumerate(steps):
        for which, diff in (("scene_diff_before", step.scene_diff_before), ("scene_diff_after", step.scene_diff_after)):
            if diff is None:
                continue
            unknown = ctx.unknown_acm_names(diff, added)
            if unknown:
                message = (f"step {k} ('{step.name}'): {which}'s allowed collision matrix names {unknown}, which are "
                           f"neither links of robot '{ctx.model.name}' nor collision objects")
                ctx.log("warning", f"task solution: {message}; applied as it is, as move_group does")
            try:
                trial = ctx.scene_with_diff(diff, base=trial, check_acm=False)
            except RequestError as exc:
                message = f"step {k} ('{step.name}'): {which} refused: {exc.message}"
                ctx.log("warning", f"task solution refused: {message}")
                return SolutionResult(MoveItErrorCode(exc.moveit_code, message, SOURCE), failed_step=k)
            added |= {o.id for o in diff.world.collision_objects}
            added |= {a.object.id for a in diff.robot_state.attached_collision_objects}
    return ctx.executor.execute_solution(steps, ctx.apply_diff_live, ctx.scene_copy())
