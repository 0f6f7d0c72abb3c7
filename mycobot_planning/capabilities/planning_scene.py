"""move_group's planning scene capabilities (MoveIt: MoveGroupGetPlanningSceneService and
ApplyPlanningSceneService, /get_planning_scene and /apply_planning_scene) on the monitored scene."""
from __future__ import annotations

from interfaces_py.msgs import PlanningScene as PlanningSceneMsg

from .move_group_context import MoveGroupContext

__all__ = ["apply_planning_scene", "get_planning_scene"]


def get_planning_scene(ctx: MoveGroupContext) -> PlanningSceneMsg:
    """The whole monitored scene (world, current state, attached objects, ACM)."""
    return ctx.scene_msg()


def apply_planning_scene(ctx: MoveGroupContext, scene: PlanningSceneMsg) -> None:
    """Apply a scene or scene diff as one change (RequestError, nothing applied, when refused)."""
    ctx.apply_planning_scene(scene)
