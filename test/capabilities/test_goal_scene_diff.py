"""Goals that change nothing when they fail (issue 27, half-applied goals), without ROS.

* move_action's planning_options.planning_scene_diff is planned with and never applied to the
  monitored scene: a plan-only goal, a refused goal (unknown group) and a failed plan leave the
  live scene as it was; an ACM-only diff is honoured (the plan it allows succeeds).
* set_planner_params is all or nothing, its keys checked against the planner's declared
  parameters and their types.
"""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import (
    AllowedCollisionMatrix,
    CollisionObject,
    MoveItErrorCode,
    PlanningScene as PlanningSceneMsg,
    PlanningSceneWorld,
)
from mycobot_planning.capabilities import move_action, planner_query
from mycobot_planning.capabilities.move_group_context import RequestError
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.planners.ompl import OmplPlanner
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.transforms import make_pose
from test_request_budgets import ARM, _core

GOAL = [1.0, -1.0, -0.8, 0.3, 0.5, 0.8]


@pytest.fixture()
def core(mycobot):
    return _core(mycobot, PlanningPipeline())


def _blocker_at_goal(model) -> CollisionObject:
    """A box around the flange at GOAL: the goal state collides with it."""
    state = RobotState(model)
    state.set_joint_positions(dict(zip(ARM, GOAL)))
    position = state.frame_pose("link6_flange")[:3, 3]
    return CollisionObject.box("blocker", [0.05, 0.05, 0.05], make_pose(list(position)))


def _diff(*objects: CollisionObject, acm: AllowedCollisionMatrix | None = None) -> PlanningSceneMsg:
    diff = PlanningSceneMsg(world=PlanningSceneWorld(collision_objects=list(objects)), is_diff=True)
    if acm is not None:
        diff.allowed_collision_matrix = acm
    return diff


def _request(group: str = "arm") -> list[tuple[MotionPlanRequest, str]]:
    return [(MotionPlanRequest(group, JointGoal(dict(zip(ARM, GOAL)), 1e-3), allowed_planning_time=5.0,
                               num_planning_attempts=1), "world")]


def _live(core) -> tuple[list[str], dict]:
    msg = core.scene_msg()
    return sorted(o.id for o in msg.world.collision_objects), msg.allowed_collision_matrix.to_dict()


def test_a_plan_only_goal_plans_with_its_diff_and_leaves_the_live_scene_alone(core, mycobot):
    before = _live(core)
    planned, executed = move_action.plan_and_execute(core, _request(), plan_only=True,
                                                     scene_diff=_diff(CollisionObject.box("far", [0.05] * 3,
                                                                                          make_pose([1.0, 1.0, 1.0]))))
    assert planned.error_code.val == MoveItErrorCode.SUCCESS and executed is None
    assert _live(core) == before  # MoveIt keeps nothing of a goal's diff


def test_the_diff_is_honoured_and_a_failed_goal_changes_nothing(core, mycobot):
    before = _live(core)
    planned, _ = move_action.plan_and_execute(core, _request(), plan_only=True, scene_diff=_diff(_blocker_at_goal(mycobot)))
    assert planned.error_code.val != MoveItErrorCode.SUCCESS  # the goal state collides with the diff's box
    assert "blocker" not in _live(core)[0]
    planned, _ = move_action.plan_and_execute(core, _request("legs"), plan_only=True,
                                              scene_diff=_diff(CollisionObject.box("kept", [0.05] * 3,
                                                                                   make_pose([1.0, 1.0, 1.0]))))
    assert planned.error_code.val == MoveItErrorCode.INVALID_GROUP_NAME
    assert _live(core) == before


def test_an_acm_only_diff_is_honoured(core, mycobot):
    core.apply_collision_objects([_blocker_at_goal(mycobot)])
    before = _live(core)
    planned, _ = move_action.plan_and_execute(core, _request(), plan_only=True)
    assert planned.error_code.val != MoveItErrorCode.SUCCESS  # blocked in the live scene
    # a diff's matrix replaces the scene's (MoveIt's setPlanningSceneDiffMsg): the live one, plus the box allowed
    allow = core.scene_msg().allowed_collision_matrix
    allow.default_entry_names = [*allow.default_entry_names, "blocker"]
    allow.default_entry_values = [*allow.default_entry_values, True]
    planned, _ = move_action.plan_and_execute(core, _request(), plan_only=True, scene_diff=_diff(acm=allow))
    assert planned.error_code.val == MoveItErrorCode.SUCCESS, planned.error_code.message
    assert _live(core) == before  # the live matrix did not take the entry


def test_a_diff_naming_nothing_is_refused_before_planning(core):
    ghost = AllowedCollisionMatrix(default_entry_names=["ghost"], default_entry_values=[True])
    with pytest.raises(RequestError, match="ghost"):
        move_action.plan_and_execute(core, _request(), plan_only=True, scene_diff=_diff(acm=ghost))


# ----------------------------------------------------------------------------- set_planner_params
@pytest.mark.parametrize("params, words", [
    ({"range": "0.5", "goal_bias": "0.1", "foo": "1"}, "unknown parameter 'foo'"),
    ({"range": "NaN"}, "NaN"),
    ({"range": "-1"}, ">= 0"),
    ({"goal_bias": "banana"}, "expected a float"),
    ({"range": "1e400"}, "finite"),
    ({"range": "1" * 100_000}, "longer than"),
    ({"range\x1b[31m": "0.5"}, "control characters"),
    ({"range": "0.5\x00"}, "control characters"),
    ({"type": "geometric::PRM"}, "cannot change"),
    ({"max_planning_threads": "4"}, "cannot change"),
])
def test_set_planner_params_is_all_or_nothing_and_checked(core, params, words):
    before = planner_query.get_planner_params(core, "ompl", "RRTkConfigDefault")
    problem = planner_query.set_planner_params(core, "ompl", "RRTkConfigDefault", params)
    assert problem is not None and words in problem, problem
    assert planner_query.get_planner_params(core, "ompl", "RRTkConfigDefault") == before


def test_set_planner_params_applies_valid_values():
    planner = OmplPlanner()
    assert planner.set_planner_params("RRTkConfigDefault", {"range": "0.25", "goal_bias": "0.1",
                                                            "longest_valid_segment_fraction": "0.01"}) is None
    params = planner.planner_params("RRTkConfigDefault")
    assert float(params["range"]) == 0.25 and float(params["goal_bias"]) == 0.1
    assert planner.config.planner_configs["RRTkConfigDefault"].context["longest_valid_segment_fraction"] == 0.01
    assert planner.set_planner_params("RRTkConfigDefault", {"type": "geometric::RRT"}) is None
    assert np.isclose(float(planner.planner_params("RRTkConfigDefault")["range"]), 0.25)
