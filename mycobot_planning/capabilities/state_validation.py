"""move_group's state validation capability (MoveIt: MoveGroupStateValidationService,
/check_state_validity): collisions and joint limits of a state merged onto the current one."""
from __future__ import annotations

from typing import Any

import numpy as np

from interfaces_py.msgs import MoveItErrorCode, RobotState as RobotStateMsg

from ..core.kinematic_constraints.kinematic_constraints import PathConstraints
from ..core.robot_state.robot_state import RobotState

from .move_group_context import MoveGroupContext, RequestError
from .state_queries import ValidityAnswer

__all__ = ["check_state_validity", "evaluate_constraints"]


def check_state_validity(ctx: MoveGroupContext, state: RobotStateMsg | None = None, group: str = "",
                         constraints: Any = None) -> tuple[MoveItErrorCode, ValidityAnswer]:
    """Whether ``state`` (None: the current state) is collision-free, within the limits and (with
    ``constraints``, path constraints' JSON form: MoveIt's GetStateValidity constraints) satisfies
    the constraints, each one's result in ``constraint_results``; the error code says why the
    question could not be answered. Never raises for bad input."""
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
        resolved = ctx.resolve_path_constraints(constraints, scene)
    except RequestError as exc:
        return MoveItErrorCode(exc.moveit_code, exc.message, "check_state_validity"), ValidityAnswer(False)
    answer = ctx.queries.check_validity(scene)
    if resolved:
        answer.constraint_results = evaluate_constraints(resolved, scene.current_state)
        answer.valid = answer.valid and all(satisfied for satisfied, _ in answer.constraint_results)
    return ok, answer


def evaluate_constraints(constraints: PathConstraints, state: RobotState) -> list[tuple[bool, float]]:
    """(satisfied, distance from being satisfied) of each constraint at ``state`` (joints, then
    orientations, then positions): rad beyond the joint's bounds, rad beyond the orientation
    tolerance, m from the nearest region's centre for a point outside every region."""
    results: list[tuple[bool, float]] = []
    for joint in constraints.joints:
        value = state.joint_position(joint.joint)
        excess = max(0.0, value - (joint.position + joint.tolerance_above), (joint.position - joint.tolerance_below) - value)
        results.append((joint.violation(state) is None, float(excess)))
    if constraints.orientations or constraints.positions:
        poses = state.frame_poses(constraints.links)
        for orientation in constraints.orientations:
            error = orientation.error(poses[orientation.link])
            results.append((orientation.violation(poses) is None,
                            float(np.max(np.maximum(error - orientation.tolerances, 0.0)))))
        for position in constraints.positions:
            ok = position.violation(poses) is None
            point = position.point(poses[position.link])
            distance = 0.0 if ok else min(float(np.linalg.norm(region.local(point))) for region in position.regions)
            results.append((ok, distance))
    return results
