"""Helpers shared by the stages: ik frames, goals, and turning planner results into solutions."""
from __future__ import annotations

from typing import Any

import numpy as np

from ...core.errors import SceneError
from ...core.planning_scene import PlanningScene
from ...core.robot_model import RobotModel
from ..geometry import PoseStamped, frame_transform, rigidly_connected_link


def default_tip(model: RobotModel, group: str) -> str:
    """The link a group moves to reach poses: its end effector's parent link when the group
    carries an end effector (MoveIt's getOnlyOneEndEffectorTip), else the chain tip."""
    for eef in model.end_effectors.values():
        if eef.parent_group == group:
            return eef.parent_link
    return model.group(group).tip_link


def robot_tip_for_frame(ik_frame: PoseStamped | None, scene: PlanningScene, group: str) -> tuple[str, np.ndarray]:
    """MTC's utils::getRobotTipForFrame: the robot link to plan for and the world pose of the
    ik frame at the scene's current state. Raises SceneError for unknown or world frames."""
    state = scene.current_state
    if ik_frame is None:
        link = default_tip(scene.robot_model, group)
        return link, state.frame_pose(link)
    if not ik_frame.frame_id:
        raise SceneError("ik_frame needs a frame_id (a robot link or an attached object)")
    link = rigidly_connected_link(scene, ik_frame.frame_id)
    return link, frame_transform(scene, ik_frame.frame_id, state) @ ik_frame.pose


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
