"""move_group's planner query capability (MoveIt: MoveGroupQueryPlannersService,
/query_planner_interface, /get_planner_params, /set_planner_params): whatever planners the
registry holds (core.planning_interface.planner_manager)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from .move_group_context import MoveGroupContext

__all__ = ["MAX_PARAM_TEXT", "PlannerInterfaceDescription", "get_planner_params", "params_text_problem",
           "query_planner_interfaces", "set_planner_params"]

#: characters at most in a planner parameter's name or value (a number or a word fits easily)
MAX_PARAM_TEXT = 256


@dataclass
class PlannerInterfaceDescription:
    """moveit_msgs/PlannerInterfaceDescription."""

    name: str
    pipeline_id: str
    planner_ids: list[str]


def params_text_problem(params: Mapping[str, str]) -> str | None:
    """Why planner parameters cannot even be read (before any planner sees them), or None:
    empty or over-long names and values, control characters (terminal escapes, NUL)."""
    for key, value in params.items():
        for what, text in (("name", key), ("value", value)):
            if not isinstance(text, str):
                return f"planner parameter {what}s must be strings, got {type(text).__name__}"
            shown = repr(text[:40]) + ("..." if len(text) > 40 else "")
            if what == "name" and not text.strip():
                return "a planner parameter has an empty name"
            if len(text) > MAX_PARAM_TEXT:
                return f"planner parameter {what} {shown} is longer than {MAX_PARAM_TEXT} characters"
            if any(ord(c) < 32 or ord(c) == 127 for c in text):
                return f"planner parameter {what} {shown} contains control characters"
    return None


def query_planner_interfaces(ctx: MoveGroupContext) -> list[PlannerInterfaceDescription]:
    return [PlannerInterfaceDescription(manager.description, pipeline_id, manager.planner_ids())
            for pipeline_id, manager in ctx.pipeline.managers.items()]


def get_planner_params(ctx: MoveGroupContext, pipeline_id: str, planner_config: str, group: str = "") -> dict[str, str]:
    """The parameters of one planner configuration ({} when unknown), as strings."""
    manager = ctx.pipeline.manager(pipeline_id)
    return manager.planner_params(planner_config, group) if manager is not None else {}


def set_planner_params(ctx: MoveGroupContext, pipeline_id: str, planner_config: str, params: Mapping[str, str],
                       replace: bool = False) -> str | None:
    """Change a planner configuration's parameters (every plan after this uses them); None when applied,
    else why not (nothing changed)."""
    if ctx.pipeline.manager(pipeline_id) is None:
        return f"unknown planning pipeline {pipeline_id!r}; known: {', '.join(ctx.pipeline.pipeline_ids)}"
    problem = params_text_problem(params)
    if problem is not None:
        return problem
    problem = ctx.pipeline.manager(pipeline_id).set_planner_params(planner_config, params, replace)
    if problem is not None:
        return problem
    if ctx.workers is not None:
        ctx.workers.parameters_changed(pipeline_id, planner_config, params, replace)
    ctx.log("info", f"planner configuration {pipeline_id or 'ompl'}/{planner_config}: parameters now "
                    f"{get_planner_params(ctx, pipeline_id, planner_config)}")
    return None
