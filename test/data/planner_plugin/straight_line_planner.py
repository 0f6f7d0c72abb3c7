"""A third-party planner in one module: a straight line in joint space to a joint or named goal.

It is what the planner-plugin tests install (this folder on PYTHONPATH: the dist-info next to it
registers ``straight_line`` in the ``mycobot_planning.planners`` entry-point group) to show that
adding a planner needs no edit of the package.
"""
from __future__ import annotations

import time
from typing import Mapping, Sequence

import numpy as np

from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.core.planning_interface.planner_manager import PlannerSettings
from mycobot_planning.core.planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    MotionPlanResponse,
    NamedGoal,
    PlanningFailure,
    check_group,
    check_scaling,
    failure,
    joint_goal_vector,
    start_state_of,
    success,
    time_group_path,
)
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene

PIPELINE_ID = "straight_line"
PLANNER_ID = "StraightLine"
STEPS = 20


class StraightLinePlanner:
    pipeline_id = PIPELINE_ID
    description = "Straight line (test plugin)"
    enforces_path_constraints = False

    def __init__(self, settings: PlannerSettings | None = None) -> None:
        self.settings = settings

    def planner_ids(self, group: str = "") -> list[str]:
        return [PLANNER_ID]

    def planner_id_problem(self, planner_id: str, groups: Sequence[str] = ()) -> str | None:
        return None if planner_id in ("", PLANNER_ID) else f"'{planner_id}' is not '{PLANNER_ID}'"

    def can_service_request(self, request: MotionPlanRequest) -> bool:
        return isinstance(request.goal, (JointGoal, NamedGoal)) and self.planner_id_problem(request.planner_id) is None

    def planner_params(self, planner_id: str, group: str = "") -> dict[str, str]:
        return {"steps": str(STEPS)}

    def set_planner_params(self, planner_id: str, params: Mapping[str, str], replace: bool = False) -> str | None:
        return "the straight line has no settable parameters"

    def plan(self, scene: PlanningScene, request: MotionPlanRequest) -> MotionPlanResponse:
        started = time.perf_counter()
        try:
            if not self.can_service_request(request):
                raise failure(MoveItErrorCode.INVALID_GOAL_CONSTRAINTS, "the straight line takes joint goals only")
            model = scene.robot_model
            jmg = check_group(model, request.group)
            velocity, acceleration = check_scaling(model, request)
            start = start_state_of(scene, request)
            goal = joint_goal_vector(model, jmg, request.goal)
            begin = start.group_positions(jmg.name)
            path = np.linspace(begin, goal, STEPS + 1)
            probe = start.copy()
            for row in path:
                probe.set_group_positions(jmg.name, row)
                if not scene.is_state_valid(probe):
                    raise failure(MoveItErrorCode.PLANNING_FAILED, "the straight line collides")
            trajectory = time_group_path(model, jmg, path, velocity, acceleration)
            return success(trajectory, started, request, start, path=path)
        except PlanningFailure as exc:
            return exc.to_response(started, request)
