"""What the hybrid planning manager and the global planner check in a goal before any planning:
one motion sequence item, a group, finite numbers (a bad goal is answered with a reason, never a
traceback)."""
from __future__ import annotations

import math
from array import array
from typing import Any

from moveit_msgs.msg import MoveItErrorCodes

__all__ = ["GoalError", "first_non_finite", "motion_plan_request"]


class GoalError(ValueError):
    """A goal refused before planning: a MoveItErrorCodes value and the reason."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


def first_non_finite(msg: Any, path: str = "") -> str | None:
    """The dotted path of the first NaN or infinite number in a ROS message, or None."""
    for name in msg.get_fields_and_field_types():
        value = getattr(msg, name)
        where = f"{path}.{name}" if path else name
        if isinstance(value, float):
            if not math.isfinite(value):
                return where
        elif hasattr(value, "get_fields_and_field_types"):
            found = first_non_finite(value, where)
            if found:
                return found
        elif isinstance(value, (list, tuple, array)) or hasattr(value, "tolist"):
            for k, item in enumerate(value):
                if isinstance(item, float):  # numpy's float64 too
                    if not math.isfinite(item):
                        return f"{where}[{k}]"
                elif hasattr(item, "get_fields_and_field_types"):
                    found = first_non_finite(item, f"{where}[{k}]")
                    if found:
                        return found
    return None


def motion_plan_request(planning_group: str, motion_sequence: Any) -> Any:
    """The one MotionPlanRequest of a HybridPlanner/GlobalPlanner goal, its group_name filled from
    ``planning_group`` when empty; GoalError when the goal cannot be planned."""
    items = list(motion_sequence.items)
    if not items:
        raise GoalError(MoveItErrorCodes.INVALID_MOTION_PLAN, "the goal's motion_sequence has no items")
    if len(items) > 1:
        raise GoalError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                        f"the goal's motion_sequence has {len(items)} items; hybrid planning plans one "
                        "(MoveIt's global planner would plan the first only)")
    request = items[0].req
    group = planning_group.strip()
    if not request.group_name:
        request.group_name = group
    if not request.group_name:
        raise GoalError(MoveItErrorCodes.INVALID_GROUP_NAME, "no planning group: set planning_group or the "
                                                              "request's group_name")
    if group and request.group_name != group:
        raise GoalError(MoveItErrorCodes.INVALID_GROUP_NAME,
                        f"planning_group '{group}' differs from the request's group_name '{request.group_name}'")
    bad = first_non_finite(items[0])
    if bad:
        raise GoalError(MoveItErrorCodes.INVALID_MOTION_PLAN,
                        f"motion_sequence.items[0].{bad} is not a finite number")
    if not len(request.goal_constraints):
        raise GoalError(MoveItErrorCodes.INVALID_GOAL_CONSTRAINTS, "the request has no goal_constraints")
    return request
