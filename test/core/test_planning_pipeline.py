"""PlanningPipeline: one entry point dispatching to every core planner by pipeline id."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planning_interface.planning_interface import MotionPlanRequest, NamedGoal
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory


@pytest.mark.parametrize(
    "pipeline_id,planner_id",
    [("ompl", ""), ("ompl", "RRTConnectkConfigDefault"), ("pilz_industrial_motion_planner", "PTP"), ("joint_interpolation", "")],
)
def test_every_pipeline_reaches_home(mycobot: RobotModel, pipeline: PlanningPipeline, pipeline_id: str, planner_id: str):
    scene = PlanningScene(mycobot)
    start = RobotState(mycobot)
    start.set_named("ready")
    request = MotionPlanRequest(
        "arm", NamedGoal("home"), start_state=start, pipeline_id=pipeline_id, planner_id=planner_id, seed=1
    )
    response = pipeline.plan(scene, request)
    assert response.success, response.error_code
    assert np.allclose(response.trajectory.positions[-1], 0.0, atol=1e-6)
    report = validate_trajectory(scene, response.trajectory, "arm", start)
    assert report.valid, report.problems


def test_unknown_pipeline(mycobot: RobotModel, pipeline: PlanningPipeline):
    response = pipeline.plan(PlanningScene(mycobot), MotionPlanRequest("arm", NamedGoal("home"), pipeline_id="trajopt"))
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert "unknown planning pipeline 'trajopt'" in response.message
    assert not response


def test_scene_current_state_is_the_default_start(mycobot: RobotModel, pipeline: PlanningPipeline):
    scene = PlanningScene(mycobot)
    state = RobotState(mycobot)
    state.set_joint_positions({"link1_to_link2": math.pi / 6})
    scene.set_current_state(state)
    response = pipeline.plan(scene, MotionPlanRequest("arm", NamedGoal("ready"), seed=2))
    assert response.success
    assert response.trajectory.positions[0][0] == pytest.approx(math.pi / 6)
