"""move_group's state validation capability (MoveIt: MoveGroupStateValidationService,
/check_state_validity): collisions and joint limits of a state merged onto the current one."""
from __future__ import annotations

from interfaces_py.msgs import MoveItErrorCode, RobotState as RobotStateMsg

from .move_group_context import MoveGroupContext, RequestError
from .state_queries import ValidityAnswer

__all__ = ["check_state_validity"]


def check_state_validity(ctx: MoveGroupContext, state: RobotStateMsg | None = None, group: str = ""
                         ) -> tuple[MoveItErrorCode, ValidityAnswer]:
    """Whether ``state`` (None: the current state) is collision-free and within the limits; the
    error code says why the question could not be answered. Never raises for bad input."""
    ok = MoveItErrorCode(MoveItErrorCode.SUCCESS, "", "check_state_validity")
    try:
        if group and not ctx.model.has_group(group):
            raise RequestError(MoveItErrorCode.INVALID_GROUP_NAME,
                               f"unknown planning group {group!r}; known: {', '.join(ctx.model.group_names)}")
        if state is not None and not state.joint_names and not state.attached_collision_objects:
            state = None
        if state is not None and state.joint_names:
            outside = ctx.limit_problems(state.joint_positions())
            if outside:
                return ok, ValidityAnswer(False, [], outside)
        scene = ctx.start_scene(state, ctx.model.variable_names if state is None else [])
    except RequestError as exc:
        return MoveItErrorCode(exc.moveit_code, exc.message, "check_state_validity"), ValidityAnswer(False)
    return ok, ctx.queries.check_validity(scene)
