"""The seeds' fallbacks_move_to scenario on the planning core, planner by planner.

Target: 'ready' with link1_to_link2 = +tau/8. Starts: (a) 'ready' with link1_to_link2 = -tau/8,
(b) 'ready' with link1_to_link2 = +tau/8 and link3_to_link4 = 0, (c) as (a) beside a thin box.
The seeds report: Cartesian fails for all three, the industrial PTP succeeds for (a) and (b) and
fails for (c) naming the contact, OMPL succeeds for all three.
"""
from __future__ import annotations

import math

import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planners.cartesian.cartesian_path import compute_cartesian_path
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

TAU = 2 * math.pi
#: MTC's CartesianPath solver default jump threshold.
MTC_JUMP_THRESHOLD = 1.5


def case(model: RobotModel, name: str) -> tuple[PlanningScene, RobotState]:
    scene = PlanningScene(model)
    start = RobotState(model)
    start.set_named("ready")
    if name == "b":
        start.set_joint_positions({"link1_to_link2": TAU / 8, "link3_to_link4": 0.0})
    else:
        start.set_joint_positions({"link1_to_link2": -TAU / 8})
    if name == "c":
        scene.add_object(CollisionObject.box("box", [0.005, 0.1, 0.32], make_pose([0.02, -0.20, 0.16]), frame_id="base_link"))
    return scene, start


def target(model: RobotModel) -> RobotState:
    state = RobotState(model)
    state.set_named("ready")
    state.set_joint_positions({"link1_to_link2": TAU / 8})
    return state


@pytest.mark.parametrize("name", ["a", "b", "c"])
def test_cartesian_fails_for_all_three(mycobot: RobotModel, name: str):
    scene, start = case(mycobot, name)
    goal_pose = target(mycobot).frame_pose("link6_flange")
    result = compute_cartesian_path(scene, "arm", start, [goal_pose], eef_step=0.01, jump_threshold=MTC_JUMP_THRESHOLD)
    assert result.fraction < 1.0
    assert result.stop_reason in ("collision", "joint_space_jump", "no_ik_solution")


@pytest.mark.parametrize("name,succeeds", [("a", True), ("b", True), ("c", False)])
def test_ptp_succeeds_where_the_joint_line_is_free(mycobot: RobotModel, pipeline: PlanningPipeline, name: str, succeeds: bool):
    scene, start = case(mycobot, name)
    request = MotionPlanRequest(
        "arm",
        JointGoal(target(mycobot).group_positions("arm")),
        start_state=start,
        pipeline_id="pilz_industrial_motion_planner",
        planner_id="PTP",
    )
    response = pipeline.plan(scene, request)
    if succeeds:
        assert response.success, response.error_code
        assert validate_trajectory(scene, response.trajectory, "arm", start).valid
    else:
        assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
        assert "Invalid states at index locations: [" in response.message
        assert "contact between 'box' (Object)" in response.message


@pytest.mark.parametrize("name", ["a", "b", "c"])
def test_ompl_succeeds_for_all_three(mycobot: RobotModel, pipeline: PlanningPipeline, name: str):
    scene, start = case(mycobot, name)
    request = MotionPlanRequest("arm", JointGoal(target(mycobot).group_positions("arm")), start_state=start, seed=5)
    response = pipeline.plan(scene, request)
    assert response.success, response.error_code
    report = validate_trajectory(scene, response.trajectory, "arm", start)
    assert report.valid, report.problems
