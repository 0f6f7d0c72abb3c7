"""Helpers shared by the stages: ik frames, goals, and turning planner results into solutions."""
from __future__ import annotations

from typing import Any, Callable, Iterable

from ...core.robot_model.robot_model import RobotModel
from ..geometry import default_tip, robot_tip_for_frame

__all__ = ["default_tip", "first_conversion", "group_of_eef", "joint_goal_values", "robot_tip_for_frame"]


def group_of_eef(model: RobotModel, eef: str) -> str:
    """The group an end effector is attached to (to derive 'group' from 'eef')."""
    return model.end_effectors[eef].parent_group


def joint_goal_values(model: RobotModel, group: str, goal: Any) -> dict[str, float] | None:
    """A joint-space goal (named state or joint map) as joint values; None for other goals.

    Raises ValueError naming the problem (unknown named state, joint outside the group)."""
    if isinstance(goal, str):
        return dict(model.named_state(goal, group))
    if isinstance(goal, dict):
        joints = model.group(group).joint_names
        unknown = [name for name in goal if name not in joints]
        if unknown:
            raise ValueError(f"goal joints {unknown} are not part of group '{group}' (joints: {list(joints)})")
        return {str(k): float(v) for k, v in goal.items()}
    return None


def first_conversion(value: Any, converters: Iterable[Callable[[Any], Any]], expected: str) -> Any:
    """What the first of ``converters`` makes of ``value`` (one that raises TypeError or
    ValueError does not accept it); TypeError saying ``expected`` when none accepts it."""
    for convert in converters:
        try:
            return convert(value)
        except (TypeError, ValueError):
            pass
    raise TypeError(expected)
