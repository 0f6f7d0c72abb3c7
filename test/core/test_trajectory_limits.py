"""Trajectories beyond the joint velocity/acceleration limits are refused before anything moves,
by the planning server's execution (prepare_trajectory) and by the controller (the follower), and
the reason names the joint, the point and by how much (issue 13). Planned trajectories pass."""
from __future__ import annotations

import numpy as np
import pytest

from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint, MoveItErrorCode
from mycobot_planning.core import MotionPlanRequest, NamedGoal, PlanningPipeline, PlanningScene, RobotState
from mycobot_planning.core.trajectory_execution import ExecutionError, prepare_trajectory
from mycobot_planning.core.robot_trajectory.robot_trajectory import timed_to_joint_trajectory
from mycobot_planning.mock_control.joint_trajectory_follower import JointTrajectoryFollower, TrajectoryCommand
from mycobot_planning.core.trajectory_processing.trajectory_limits import motion_limit_problem

ARM = ["link1_to_link2", "link2_to_link3", "link3_to_link4", "link4_to_link5", "link5_to_link6", "link6_to_link6_flange"]
VMAX, AMAX = np.full(6, 2.792527), np.full(6, 5.0)  # config/joint_limits.yaml


def _whip(times=(0.0, 0.001), far=1.5, velocities=None) -> JointTrajectory:
    """1.5 rad on joint2 in 1 ms: about 540x its velocity limit."""
    points = []
    for k, t in enumerate(times):
        q = [0.0] * 6
        q[1] = far * k / (len(times) - 1)
        points.append(JointTrajectoryPoint(positions=q, velocities=velocities[k] if velocities else [],
                                           time_from_start=t))
    return JointTrajectory(joint_names=ARM, points=points)


def test_the_check_names_joint_point_and_factor():
    problem = motion_limit_problem(ARM, np.array([0.0, 0.001]), np.array([[0.0] * 6, [0, 1.5, 0, 0, 0, 0]]),
                                   None, None, VMAX, AMAX)
    assert problem is not None
    assert "trajectory point 1: joint 'link2_to_link3' velocity 1500" in problem and "537x" in problem, problem
    assert "moves 1.5 rad in 0.001 s" in problem


@pytest.mark.parametrize("velocities, accelerations, words", [
    ([[0.0] * 6, [0, 3.5, 0, 0, 0, 0]], None, "trajectory point 1: joint 'link2_to_link3' velocity 3.5"),
    ([[0.0] * 6, [0.0] * 6], [[0.0] * 6, [0, 0, 0, -9.0, 0, 0]], "joint 'link4_to_link5' acceleration 9"),
])
def test_stated_velocities_and_accelerations_are_checked(velocities, accelerations, words):
    positions = np.array([[0.0] * 6, [0.0, 0.01, 0, 0, 0, 0]])
    problem = motion_limit_problem(ARM, np.array([0.0, 1.0]), positions, np.array(velocities),
                                   None if accelerations is None else np.array(accelerations), VMAX, AMAX)
    assert problem is not None and words in problem, problem


def test_accelerations_implied_by_positions_alone_are_checked():
    # 0 -> 1 rad/s -> 0 within 20 ms: 100 rad/s^2 at least, far over 5 rad/s^2
    problem = motion_limit_problem(ARM, np.array([0.0, 0.01, 0.02]),
                                   np.array([[0.0] * 6, [0.0] * 6, [0.01, 0, 0, 0, 0, 0]]), None, None, VMAX, AMAX)
    assert problem is not None and "joint 'link1_to_link2' acceleration 50" in problem, problem


def test_the_tolerance_is_relative_to_the_limit():
    positions = np.array([[0.0] * 6, [VMAX[0] * 1.04, 0, 0, 0, 0, 0]])
    assert motion_limit_problem(ARM, np.array([0.0, 1.0]), positions, None, None, VMAX, AMAX, 0.05) is None
    assert motion_limit_problem(ARM, np.array([0.0, 1.0]), positions, None, None, VMAX, AMAX, 0.01) is not None


def test_prepare_trajectory_refuses_the_whip_and_stated_overspeed(mycobot):
    with pytest.raises(ExecutionError) as info:
        prepare_trajectory(mycobot, _whip())
    assert info.value.code == MoveItErrorCode.INVALID_MOTION_PLAN and "link2_to_link3" in info.value.message
    with pytest.raises(ExecutionError, match="velocity 4"):
        prepare_trajectory(mycobot, _whip(times=(0.0, 10.0), far=0.1,
                                          velocities=[[0.0] * 6, [0, 4.0, 0, 0, 0, 0]]))


def test_the_follower_refuses_before_moving_including_the_lead_in_from_the_current_position():
    follower = JointTrajectoryFollower(ARM, [-3.0] * 6, [3.0] * 6, velocity_limits=VMAX, acceleration_limits=AMAX,
                                       name="arm_controller")
    whip = TrajectoryCommand.from_arrays(ARM, [0.0, 0.001], [[0.0] * 6, [0, 1.5, 0, 0, 0, 0]])
    result = follower.submit(whip, now=0.0)
    assert not result.accepted and "link2_to_link3" in result.reason and "velocity 1500" in result.reason
    lead_in = TrajectoryCommand.from_arrays(ARM, [0.001], [[0, 1.5, 0, 0, 0, 0]])
    result = follower.submit(lead_in, now=0.0)
    assert not result.accepted and "reaching the first point from where the joints are" in result.reason
    follower.update(0.5)
    assert np.allclose(follower.positions, 0.0)  # nothing moved


def test_planned_trajectories_pass_both_checks(mycobot):
    scene = PlanningScene(mycobot)
    start = RobotState(mycobot)
    start.set_named("home")
    scene.set_current_state(start)
    response = PlanningPipeline().plan(scene, MotionPlanRequest("arm", NamedGoal("ready"), seed=3))
    assert response.success
    for period in (None, 0.01):
        sent = timed_to_joint_trajectory(response.trajectory, period)
        prepare_trajectory(mycobot, sent, limit_tolerance=0.001)  # planned: within rounding of the limits
        follower = JointTrajectoryFollower(ARM, mycobot.lower_limits[:6], mycobot.upper_limits[:6],
                                           start.positions[:6], velocity_limits=VMAX, acceleration_limits=AMAX)
        command = TrajectoryCommand.from_arrays(
            sent.joint_names, [p.time_from_start for p in sent.points], [p.positions for p in sent.points],
            [p.velocities for p in sent.points])
        assert follower.submit(command, now=0.0).accepted
