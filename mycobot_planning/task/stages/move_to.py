"""MoveTo: move a group to a goal (MTC's stages::MoveTo).

Goals: a named state of the group ("ready", "open"), a joint map ``{joint: value}`` (joints of
the group), a RobotState (the group's joints are taken), a PoseStamped for the ik frame, or a
PointStamped (the ik frame keeps its orientation). Propagates forward (plan from the incoming
state to the goal) or backward (plan from the incoming end state to the goal and reverse), as
the neighbours require. Cost: joint-space path length. ``path_constraints`` (a
moveit_msgs/Constraints, see task/path_constraints.py) go to the planner.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from interfaces_py.msgs import RobotState as RobotStateMsg

from ...core.robot_state.robot_state import RobotState
from ...core.transforms import inverse
from ..errors import InitStageException
from ..geometry import PointStamped, PoseStamped, as_point_stamped, as_pose_stamped, frame_transform
from ..properties import PropertySetter
from ..solvers import PlannerInterface
from ..storage import InterfaceState, SubTrajectory
from .planning_stage import PlanningStage
from .common import first_conversion, joint_goal_values, robot_tip_for_frame


def _as_goal(value: Any) -> Any:
    if isinstance(value, (str, dict, RobotState, PoseStamped, PointStamped)):
        return value
    if isinstance(value, RobotStateMsg):
        if not value.is_diff:
            raise ValueError("a RobotState message goal must be a diff (is_diff=True)")
        return dict(value.joint_positions())
    return first_conversion(value, (as_pose_stamped, as_point_stamped),
                            "expected a named state, a joint map, a RobotState, a PoseStamped or a PointStamped")


class MoveTo(PlanningStage):
    _motion = "goal"

    def __init__(self, name: str = "move to", planner: PlannerInterface | None = None) -> None:
        super().__init__(name, planner, "frame to be moved towards the goal pose")
        p = self._properties
        p.declare("goal", description="goal specification", coerce=_as_goal)
        self._declare_path_constraints()

    setGoal = PropertySetter("goal", Any)

    def _check_motion(self, robot_model: Any, group: Any, motion: Any, errors: InitStageException) -> None:
        if self._check_group("group", group, robot_model, errors) and motion is not None:
            try:
                joint_goal_values(robot_model, group, motion)
            except ValueError as exc:
                errors.push_back(self, f"property 'goal': {exc}")

    def _propagate(self, state: InterfaceState, direction: int):
        scene, failure = self._start_propagation(state)
        if failure is not None:
            return False, scene, failure
        model = scene.robot_model
        props = self._properties
        group = props["group"]
        goal = props["goal"]
        timeout = self.timeout_or(1.0)
        context = self._context
        extra = self._planning_extras()
        values = joint_goal_values(model, group, goal) if not isinstance(goal, RobotState) else None
        if isinstance(goal, RobotState) or values is not None:
            target = scene.current_state.copy()
            if isinstance(goal, RobotState):
                target.set_group_positions(group, goal.group_positions(group))
            else:
                target.set_joint_positions({k: v for k, v in values.items() if k in model.variable_names})
            scene.set_current_state(target)
            result = self._planner.plan(state.scene, scene, group, timeout, context, **extra)
        else:
            link, ik_pose = robot_tip_for_frame(props["ik_frame"], scene, group)
            if isinstance(goal, PoseStamped):
                target_pose = frame_transform(scene, goal.frame_id) @ goal.pose
            else:
                target_pose = ik_pose.copy()
                point = frame_transform(scene, goal.frame_id) @ np.append(goal.point, 1.0)
                target_pose[:3, 3] = point[:3]
            offset = inverse(scene.current_state.frame_pose(link)) @ ik_pose
            result = self._planner.plan_pose(state.scene, link, offset, target_pose, group, timeout, context, **extra)
        trajectory = self._planner.dense(result.trajectory)
        solution = SubTrajectory(None, group, planner_id=result.planner_id or self._planner.planner_id)
        return self._finish_propagation(state, scene, solution, trajectory, direction, result.success,
                                        result.message or "planning failed", result.message)
