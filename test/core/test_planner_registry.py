"""Planners as plugins (MoveIt's planning_interface::PlannerManager): every built-in planner is a
registered manager, and a planner registered from outside the package is planned with, listed,
and checked like the built-in ones. The same module through the entry-point group, over ROS:
test/ros/test_planner_plugin.py."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planning_interface.planner_manager import (
    PlannerManager,
    PlannerRegistryError,
    register_planner,
    unregister_planner,
)
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory

PLUGIN_DIR = Path(__file__).resolve().parents[1] / "data" / "planner_plugin"


@pytest.fixture()
def straight_line():
    sys.path.insert(0, str(PLUGIN_DIR))
    try:
        import straight_line_planner

        register_planner(straight_line_planner.PIPELINE_ID, straight_line_planner.StraightLinePlanner)
        yield straight_line_planner
    finally:
        unregister_planner("straight_line")
        sys.path.remove(str(PLUGIN_DIR))


def test_the_built_in_planners_are_managers():
    pipeline = PlanningPipeline()
    assert pipeline.pipeline_ids[:5] == ["ompl", "pilz_industrial_motion_planner", "joint_interpolation", "stomp",
                                         "chomp"]
    for pipeline_id, manager in pipeline.managers.items():
        assert isinstance(manager, PlannerManager), pipeline_id
        assert manager.pipeline_id == pipeline_id and manager.planner_ids()


def test_planner_ids_are_checked_by_every_pipeline():
    pipeline = PlanningPipeline()
    for known in ("", "RRTConnectkConfigDefault", "arm[RRTConnectkConfigDefault]", "PTP", "JointInterpolation"):
        assert pipeline.planner_id_problem(known, ["arm"]) is None, known
    problem = pipeline.planner_id_problem("Teleport", ["arm"])
    assert "unknown planner id 'Teleport'" in problem and "PTP" in problem


def test_a_registered_planner_plans_and_is_listed(straight_line, mycobot: RobotModel):
    pipeline = PlanningPipeline()
    assert "straight_line" in pipeline.pipeline_ids
    assert pipeline.manager("straight_line").planner_ids() == ["StraightLine"]
    assert pipeline.planner_id_problem("StraightLine") is None
    scene = PlanningScene(mycobot)
    start = RobotState(mycobot)
    start.set_named("ready")
    request = MotionPlanRequest("arm", NamedGoal("home"), start_state=start, pipeline_id="straight_line")
    response = pipeline.plan(scene, request)
    assert response.success, response.error_code
    assert np.allclose(response.trajectory.positions[-1], 0.0, atol=1e-9)
    assert validate_trajectory(scene, response.trajectory, "arm", start).valid
    # an id the planner does not have is refused by the pipeline (canServiceRequest), not planned
    other = MotionPlanRequest("arm", NamedGoal("home"), start_state=start, pipeline_id="straight_line",
                              planner_id="RRTConnectkConfigDefault")
    refused = pipeline.plan(scene, other)
    assert refused.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "is not 'StraightLine'" in refused.message
    # the shared request checks give the plugin MoveIt's codes: 7 values for a 6-joint group
    bad = MotionPlanRequest("arm", JointGoal([0.0] * 7), start_state=start, pipeline_id="straight_line")
    assert pipeline.plan(scene, bad).error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS


def test_a_pipeline_id_is_registered_once(straight_line):
    with pytest.raises(PlannerRegistryError, match="registered already"):
        register_planner("straight_line", lambda settings: straight_line.StraightLinePlanner(settings))


def test_a_planner_that_lies_about_its_id_is_refused(straight_line):
    register_planner("other_line", straight_line.StraightLinePlanner)
    try:
        with pytest.raises(ValueError, match="says its pipeline id is 'straight_line'"):
            PlanningPipeline()
    finally:
        unregister_planner("other_line")
