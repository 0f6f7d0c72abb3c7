"""What holds for every trajectory-optimisation pipeline (CHOMP, STOMP) alike: a pose goal goes
through IK and the path ends at the pose."""
from __future__ import annotations

import numpy as np
import pytest

from mycobot_planning.core.planning_interface.planning_interface import PoseGoal
from trajectory_optimizer_testing import RIGHT, TIP, arm_state, assert_plain_valid, boxed_scene, optimizer_request


@pytest.fixture(scope="module")
def boxed(mycobot):
    return boxed_scene(mycobot)


@pytest.mark.parametrize("pipeline_id", ["chomp", "stomp"])
def test_a_pose_goal_through_ik(pipeline, boxed, mycobot, pipeline_id):
    scene, start = boxed
    target = arm_state(mycobot, RIGHT).frame_pose(TIP)
    response = pipeline.plan(scene, optimizer_request(pipeline_id, PoseGoal(target), start, seed=1))
    assert_plain_valid(scene, response, start)
    end = arm_state(mycobot, response.trajectory.positions[-1]).frame_pose(TIP)
    assert np.linalg.norm(end[:3, 3] - target[:3, 3]) < 1e-3
    assert np.allclose(end[:3, :3], target[:3, :3], atol=1e-2)
