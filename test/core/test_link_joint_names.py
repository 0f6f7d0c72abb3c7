"""Link and joint names are separate namespaces (URDF, MoveIt): example-robot-data's SO-100 has
a link and a joint both named 'gripper', and a group from its base to link 'gripper' works as a
new user would set it up (the setup assistant's configuration): forward kinematics, IK round
trips and OMPL plans, every plan through the independent validator."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from mycobot_planning.core import (IKSolver, JointGoal, MotionPlanRequest, PlanningPipeline, PlanningScene,
                                   PoseGoal, RobotModel, RobotState, validate_trajectory)
from mycobot_planning.core.collision_detection.collision_matrix import sample_positions
from mycobot_planning.paths import example_robot_data_dir
from mycobot_planning.setup_assistant import GroupSpec, build_config

SO100 = "so_arm_description/urdf/so100.urdf"
GROUP = "arm"
TIP = "gripper"


@pytest.fixture(scope="module")
def so100_config(tmp_path_factory) -> Path:
    """The setup assistant's configuration of the SO-100 with group 'arm' from 'base' to 'gripper'."""
    out = tmp_path_factory.mktemp("so100")
    build_config(example_robot_data_dir() / SO100, out, groups=[GroupSpec(GROUP, base_link="base", tip_link=TIP)],
                 samples=2000)
    return out


@pytest.fixture(scope="module")
def so100(so100_config: Path) -> RobotModel:
    return RobotModel.from_config(so100_config)


def _valid_states(scene: PlanningScene, count: int, rng: np.random.Generator) -> list[RobotState]:
    model = scene.robot_model
    indices = model.group(GROUP).variable_indices
    states: list[RobotState] = []
    while len(states) < count:
        state = RobotState(model)
        state.set_group_positions(GROUP, sample_positions(model, rng, 1)[0][indices])
        if scene.is_state_valid(state):
            states.append(state)
    return states


def test_the_urdf_names_a_link_and_a_joint_alike(so100: RobotModel):
    """The premise: both namespaces hold 'gripper', and Pinocchio has a frame for each."""
    assert so100.has_link(TIP) and TIP in so100.joint_names
    types = {f.type for f in so100.pin_model.frames if f.name == TIP}
    assert types == {pin.FrameType.BODY, pin.FrameType.JOINT}
    assert so100.group(GROUP).tip_link == TIP


def test_a_link_named_like_a_joint_is_its_body_frame(so100: RobotModel):
    """The frame of link 'gripper' is the link's, not joint 'gripper''s (which moves the jaw
    and sits elsewhere): its pose is the parent joint 'wrist_roll''s child frame."""
    state = RobotState(so100)
    state.set_group_positions(GROUP, [0.3, -0.4, 0.5, 0.2, -0.6])
    frame = so100.pin_model.frames[so100.frame_id(TIP)]
    assert frame.type == pin.FrameType.BODY and frame.name == TIP
    assert so100.pin_model.names[frame.parentJoint] == "wrist_roll"
    joint_frame = so100.pin_model.getFrameId(TIP, pin.FrameType.JOINT)
    pin.framesForwardKinematics(so100.pin_model, data := so100.pin_model.createData(), state.positions)
    assert np.allclose(state.frame_pose(TIP), data.oMf[frame_id := so100.frame_id(TIP)].homogeneous)
    assert not np.allclose(data.oMf[frame_id].homogeneous, data.oMf[joint_frame].homogeneous)


def test_ik_round_trips_on_20_random_reachable_poses(so100: RobotModel):
    scene = PlanningScene(so100)
    rng = np.random.default_rng(7)
    solver = IKSolver(so100, GROUP)
    for state in _valid_states(scene, 20, rng):
        target = state.frame_pose(TIP)
        solutions = solver.solve(target, rng=rng, validity=scene.is_state_valid)
        assert solutions, f"no IK solution for the pose of {state}"
        reached = solutions[0].frame_pose(TIP)
        assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-3
        angle = np.linalg.norm(pin.log3(reached[:3, :3].T @ target[:3, :3]))
        assert angle < 1e-2
        assert scene.is_state_valid(solutions[0])


def test_ompl_plans_between_10_random_valid_states(so100: RobotModel, so100_config: Path):
    scene = PlanningScene(so100)
    rng = np.random.default_rng(11)
    pipeline = PlanningPipeline(so100_config / "ompl_planning.yaml")
    joints = so100.group(GROUP).joint_names
    states = _valid_states(scene, 20, rng)
    for k, (start, goal) in enumerate(zip(states[::2], states[1::2])):
        request = MotionPlanRequest(GROUP, JointGoal(dict(zip(joints, goal.group_positions(GROUP)))),
                                    start_state=start, seed=k + 1)
        response = pipeline.plan(scene, request)
        assert response.success, response.error_code
        report = validate_trajectory(scene, response.trajectory, GROUP, start)
        assert report, report
        assert np.allclose(response.trajectory.positions[-1], goal.group_positions(GROUP), atol=1e-3)


def test_a_pose_goal_for_link_gripper_plans(so100: RobotModel, so100_config: Path):
    """The planning interface resolves the goal's link the same way: a pose of link 'gripper'."""
    scene = PlanningScene(so100)
    rng = np.random.default_rng(3)
    start, goal = _valid_states(scene, 2, rng)
    request = MotionPlanRequest(GROUP, PoseGoal(goal.frame_pose(TIP), link=TIP, position_tolerance=1e-3,
                                                orientation_tolerance=1e-2), start_state=start, seed=5)
    response = PlanningPipeline(so100_config / "ompl_planning.yaml").plan(scene, request)
    assert response.success, response.error_code
    end = RobotState(so100)
    end.set_group_positions(GROUP, response.trajectory.positions[-1])
    assert np.linalg.norm(end.frame_pose(TIP)[:3, 3] - goal.frame_pose(TIP)[:3, 3]) < 2e-3
    assert validate_trajectory(scene, response.trajectory, GROUP, start)
