"""MoveIt's face as strict as the JSON face (issue 27), through the real moveit_msgs types:
goals that change nothing when they fail, refusals with MoveItErrorCodes values (never 99999,
never a traceback), cancels that stop planning. planning_server + mock_controllers run in real
processes (one bring-up for the module)."""
from __future__ import annotations

import math

import pytest
from action_msgs.msg import GoalStatus
from moveit_msgs.action import MoveGroup
from moveit_msgs.msg import PlannerParams
from moveit_msgs.srv import GetPlannerParams, SetPlannerParams

from ros_testing import robot_processes
from test_move_group_api import FAR, READY, C, Client, box, joint_goal, world_ids


@pytest.fixture(scope="module")
def client():
    with robot_processes() as (_, server):
        user = Client()
        user.server = server
        try:
            yield user
        finally:
            user.close()


def _move_goal(values, group: str = "arm", plan_only: bool = True, *objects) -> MoveGroup.Goal:
    goal = MoveGroup.Goal()
    goal.request = joint_goal(values, group).motion_plan_request
    goal.planning_options.plan_only = plan_only
    goal.planning_options.planning_scene_diff.is_diff = True
    goal.planning_options.planning_scene_diff.robot_state.is_diff = True
    goal.planning_options.planning_scene_diff.world.collision_objects = list(objects)
    return goal


def _result(client: Client, goal: MoveGroup.Goal):
    handle = client.send(client.move, goal)
    return client.spin_until(handle.get_result_async())


# ----------------------------------------------------------------------------- half-applied goals
def test_a_plan_only_goals_scene_diff_is_not_kept(client: Client) -> None:
    response = _result(client, _move_goal(FAR, "arm", True, box("goal_only_box", [0.3, 0.3, 0.3])))
    assert response.status == GoalStatus.STATUS_SUCCEEDED
    assert response.result.error_code.val == C.SUCCESS
    assert "goal_only_box" not in world_ids(client)


@pytest.mark.parametrize("group, values, code", [("legs", FAR, C.INVALID_GROUP_NAME),
                                                 ("arm", [math.nan] + FAR[1:], C.INVALID_GOAL_CONSTRAINTS)])
def test_a_refused_goal_changes_nothing(client: Client, group, values, code) -> None:
    response = _result(client, _move_goal(values, group, False, box("refused_box", [0.3, 0.3, 0.3])))
    assert response.status == GoalStatus.STATUS_ABORTED
    assert response.result.error_code.val == code, response.result.error_code.message
    assert "refused_box" not in world_ids(client)


def _planner_params(client: Client) -> dict[str, str]:
    request = GetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTkConfigDefault")
    params = client.call(GetPlannerParams, "/get_planner_params", request).params
    return dict(zip(params.keys, params.values))


@pytest.mark.parametrize("keys, values", [(["range", "goal_bias", "foo"], ["0.5", "0.2", "1"]),
                                          (["range"], ["NaN"]), (["range"], ["-1"]), (["goal_bias"], ["banana"]),
                                          (["range\x1b[2J"], ["0.5"]), (["range"], ["9" * 100_000]),
                                          (["range", "goal_bias"], ["0.5"])])
def test_set_planner_params_is_all_or_nothing(client: Client, keys, values) -> None:
    before = _planner_params(client)
    request = SetPlannerParams.Request(pipeline_id="ompl", planner_config="RRTkConfigDefault",
                                       params=PlannerParams(keys=keys, values=values))
    client.call(SetPlannerParams, "/set_planner_params", request)
    assert _planner_params(client) == before
    assert "Traceback" not in client.server.output()


def test_the_server_still_plans(client: Client) -> None:
    response = _result(client, _move_goal(READY))
    assert response.result.error_code.val == C.SUCCESS
