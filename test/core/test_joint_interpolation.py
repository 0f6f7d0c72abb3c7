"""MTC's JointInterpolationPlanner as a core planner: straight joint-space lines, densely
checked, timed, and independently validated; MoveIt error codes for everything that is wrong."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import RobotModelError, RobotState, StateError
from mycobot_planning.core.planners.joint_interpolation.joint_interpolation import (
    DEFAULT_MAX_STEP,
    interpolate_joint_path,
    plan_joint_interpolation,
)
from mycobot_planning.core.planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    NamedGoal,
    PoseGoal,
)
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

PANDA_READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
# Two myCobot arm states whose joint-space line sweeps the flange around the base.
LEFT = np.array([-1.2, 0.0, 1.5708, 1.5708, 0.0, 0.0])
RIGHT = np.array([1.2, 0.0, 1.5708, 1.5708, 0.0, 0.0])


def arm_state(model, values, base: RobotState | None = None) -> RobotState:
    state = RobotState(model) if base is None else base.copy()
    state.set_group_positions("arm", values)
    return state


def ready(model) -> RobotState:
    state = RobotState(model)
    state.set_named("ready", "arm")
    return state


def box_at_flange(model, arm_values, size=0.03, name="box") -> CollisionObject:
    where = arm_state(model, arm_values).frame_pose("link6_flange")[:3, 3]
    return CollisionObject.box(name, [size] * 3, make_pose(where))


def assert_straight_line(path: np.ndarray, start: np.ndarray, goal: np.ndarray, max_step: float) -> None:
    assert np.allclose(path[0], start) and np.allclose(path[-1], goal)
    steps = np.diff(path, axis=0)
    assert np.max(np.abs(steps)) <= max_step + 1e-12
    assert np.allclose(steps, steps[0])  # equal steps along one direction


def assert_validated(scene, response, group, start, vs=1.0, acc=1.0) -> None:
    assert response.success, response.message
    report = validate_trajectory(
        scene, response.trajectory, group, start_state=start, velocity_scaling=vs, acceleration_scaling=acc
    )
    assert report.valid, report.problems


# ------------------------------------------------------------------------------- success
def test_named_goal_mycobot(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    request = MotionPlanRequest("arm", NamedGoal("home"), pipeline_id="joint_interpolation")
    response = plan_joint_interpolation(scene, request)
    assert response.error_code.val == MoveItErrorCode.SUCCESS
    assert response.planner_id == "arm[JointInterpolation]" and response.group_name == "arm"
    assert_validated(scene, response, "arm", start)
    traj = response.trajectory
    assert traj.joint_names == list(mycobot.group("arm").joint_names)
    assert np.allclose(traj.positions[-1], 0.0)
    assert_straight_line(response.path, start.group_positions("arm"), np.zeros(6), DEFAULT_MAX_STEP)
    # 1.5708 rad on joints 3 and 4 at <= 0.01 rad per step.
    assert len(response.path) == math.ceil(1.5708 / DEFAULT_MAX_STEP) + 1
    assert response.start_state == start


def test_joint_goal_by_vector_and_by_name_mycobot(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    target = [0.5, -0.3, 0.8, 0.2, 0.1, 0.3]
    by_vector = plan_joint_interpolation(scene, MotionPlanRequest("arm", JointGoal(target)))
    names = mycobot.group("arm").joint_names
    by_name_goal = JointGoal(dict(zip(reversed(names), reversed(target))))
    by_name = plan_joint_interpolation(scene, MotionPlanRequest("arm", by_name_goal))
    for response in (by_vector, by_name):
        assert_validated(scene, response, "arm", start)
        assert np.allclose(response.trajectory.positions[-1], target)
    assert np.allclose(by_vector.trajectory.positions, by_name.trajectory.positions)


def test_scaling_slows_the_motion_and_respects_the_scaled_limits(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    full = plan_joint_interpolation(scene, MotionPlanRequest("arm", NamedGoal("home")))
    slow = plan_joint_interpolation(
        scene,
        MotionPlanRequest(
            "arm", NamedGoal("home"), max_velocity_scaling_factor=0.2, max_acceleration_scaling_factor=0.3
        ),
    )
    assert_validated(scene, slow, "arm", start, vs=0.2, acc=0.3)
    # The limiting joints move 1.5708 rad: bang-bang at full speed (the velocity limit is never
    # reached), a trapezoid (cruise at 0.2 * 2.7925 rad/s, ramps at 0.3 * 5 rad/s^2) when scaled.
    assert full.trajectory.duration == pytest.approx(2 * math.sqrt(1.5708 / 5.0), rel=1e-4)
    v, a = 0.2 * 2.792527, 0.3 * 5.0
    assert slow.trajectory.duration == pytest.approx(1.5708 / v + v / a, rel=1e-4)
    # The full-speed trajectory breaks the scaled limits: the validator sees the difference.
    assert not validate_trajectory(scene, full.trajectory, "arm", velocity_scaling=0.2, acceleration_scaling=0.3)


def test_pose_goal_mycobot_reaches_the_pose_nearest_the_start(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    target_joints = np.array([0.4, -0.5, 0.9, 0.3, 0.2, 0.1])
    pose = arm_state(mycobot, target_joints).frame_pose("link6_flange")
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", PoseGoal(pose), seed=3))
    assert_validated(scene, response, "arm", start)
    end = arm_state(mycobot, response.trajectory.positions[-1], base=start)
    assert np.allclose(end.frame_pose("link6_flange"), pose, atol=1e-4)
    # The solution chosen is at most as far from the start as the configuration the pose came from.
    distance = np.sum(np.abs(response.trajectory.positions[-1] - start.group_positions("arm")))
    assert distance <= np.sum(np.abs(target_joints - start.group_positions("arm"))) + 1e-3


def test_joint_and_pose_goals_panda(panda):
    start = arm_state(panda, PANDA_READY)
    scene = PlanningScene(panda, start)
    target = [0.5, -0.3, 0.2, -2.0, 0.3, 1.9, 0.5]
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", JointGoal(target)))
    assert_validated(scene, response, "arm", start)
    assert np.allclose(response.trajectory.positions[-1], target)

    tip = panda.group("arm").tip_link
    pose = arm_state(panda, target, base=start).frame_pose(tip)
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", PoseGoal(pose), seed=7))
    assert_validated(scene, response, "arm", start)
    end = arm_state(panda, response.trajectory.positions[-1], base=start)
    assert np.allclose(end.frame_pose(tip), pose, atol=1e-4)


def test_named_goal_panda_with_the_finger(panda):
    start = arm_state(panda, [0.3, -0.5, 0.2, -2.2, 0.1, 1.8, 0.4])
    start.set_joint_positions({"panda_finger_joint1": 0.03})
    scene = PlanningScene(panda, start)
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm_and_hand", NamedGoal("default")))
    assert_validated(scene, response, "arm_and_hand", start)
    goal = panda.named_state("default", "arm_and_hand")
    names = response.trajectory.joint_names
    assert np.allclose(response.trajectory.positions[-1], [goal[n] for n in names])


def test_goal_equal_to_start_is_an_empty_motion(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", NamedGoal("ready")))
    assert response.success
    assert response.trajectory.duration == 0.0
    assert validate_trajectory(scene, response.trajectory, "arm").valid


def test_start_state_defaults_to_the_scene_and_other_joints_are_kept(mycobot):
    start = arm_state(mycobot, LEFT)
    start.set_joint_positions({"gripper_controller": -0.5})
    scene = PlanningScene(mycobot, start)
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", JointGoal(RIGHT)))
    assert response.success
    assert response.start_state.joint_position("gripper_controller") == -0.5
    assert validate_trajectory(scene, response.trajectory, "arm").valid


# ------------------------------------------------------------------------------- collisions
def test_blocked_line_fails_with_the_contact(mycobot):
    scene = PlanningScene(mycobot, arm_state(mycobot, LEFT))
    scene.add_object(box_at_flange(mycobot, (LEFT + RIGHT) / 2))
    assert scene.is_state_valid(arm_state(mycobot, RIGHT))  # both ends free
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", JointGoal(RIGHT)))
    assert response.error_code.val == MoveItErrorCode.PLANNING_FAILED
    assert response.trajectory is None
    assert "'box' (Object)" in response.message and "(Robot link)" in response.message
    assert "of the way" in response.message
    # The reported step is the first colliding one: entering the box before the midpoint.
    percent = float(response.message.split("% of the way")[0].rsplit(" ", 1)[1])
    assert 20.0 < percent < 50.0


def test_interpolate_joint_path_reports_the_first_colliding_step(mycobot):
    start = arm_state(mycobot, LEFT)
    scene = PlanningScene(mycobot, start)
    path, message = interpolate_joint_path(scene, "arm", start, RIGHT)
    assert path is not None and "collision-free" in message
    assert_straight_line(path, LEFT, RIGHT, DEFAULT_MAX_STEP)
    coarse, _ = interpolate_joint_path(scene, "arm", start, RIGHT, max_step=0.1)
    assert len(coarse) == 25  # 2.4 rad in 24 steps of 0.1
    assert_straight_line(coarse, LEFT, RIGHT, 0.1)

    scene.add_object(box_at_flange(mycobot, (LEFT + RIGHT) / 2))
    blocked, message = interpolate_joint_path(scene, "arm", start, RIGHT)
    assert blocked is None
    assert "in collision: contact between 'box' (Object)" in message
    step = int(message.split("(step ")[1].split(" ")[0])
    # Every state before the reported step is valid, the reported one is not.
    for i in range(step):
        assert scene.is_state_valid(arm_state(mycobot, LEFT + (RIGHT - LEFT) * i / 240, base=start))
    assert not scene.is_state_valid(arm_state(mycobot, LEFT + (RIGHT - LEFT) * step / 240, base=start))


def test_interpolate_joint_path_bad_calls(mycobot):
    start = ready(mycobot)
    scene = PlanningScene(mycobot, start)
    with pytest.raises(RobotModelError):
        interpolate_joint_path(scene, "legs", start, np.zeros(6))
    with pytest.raises(StateError, match="expected 6 values"):
        interpolate_joint_path(scene, "arm", start, np.zeros(5))
    with pytest.raises(StateError, match="NaN"):
        interpolate_joint_path(scene, "arm", start, [0.0, 0.0, float("nan"), 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="max_step"):
        interpolate_joint_path(scene, "arm", start, np.zeros(6), max_step=0.0)


@pytest.mark.parametrize("box_at, code", [(RIGHT, MoveItErrorCode.GOAL_IN_COLLISION),
                                           (LEFT, MoveItErrorCode.START_STATE_IN_COLLISION)],
                         ids=["goal", "start"])
def test_goal_or_start_in_collision(mycobot, box_at, code):
    scene = PlanningScene(mycobot, arm_state(mycobot, LEFT))
    scene.add_object(box_at_flange(mycobot, box_at))
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", JointGoal(RIGHT)))
    assert response.error_code.val == code
    assert "'box' (Object)" in response.message


def test_pose_goal_unreachable(mycobot):
    scene = PlanningScene(mycobot, ready(mycobot))
    request = MotionPlanRequest("arm", PoseGoal(make_pose((2.0, 0.0, 0.5))), allowed_planning_time=0.2, seed=0)
    response = plan_joint_interpolation(scene, request)
    assert response.error_code.val == MoveItErrorCode.NO_IK_SOLUTION


# ------------------------------------------------------------------------------- bad requests
def test_unknown_group(mycobot):
    scene = PlanningScene(mycobot, ready(mycobot))
    response = plan_joint_interpolation(scene, MotionPlanRequest("legs", NamedGoal("home")))
    assert response.error_code.val == MoveItErrorCode.INVALID_GROUP_NAME
    assert "legs" in response.message and response.trajectory is None


@pytest.mark.parametrize(
    "goal, words",
    [
        (JointGoal([0.0, 0.0, float("nan"), 0.0, 0.0, 0.0]), "NaN"),
        (JointGoal([0.0, 0.0, 0.0]), "3 values"),
        (JointGoal([0.0, 0.0, 0.0, 0.0, 0.0, 3.5]), "outside limits"),
        (JointGoal({"link1_to_link2": 0.0}), "lacks values"),
        (NamedGoal("dance"), "dance"),
    ],
)
def test_invalid_goals(mycobot, goal, words):
    scene = PlanningScene(mycobot, ready(mycobot))
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", goal))
    assert response.error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    assert words in response.message


@pytest.mark.parametrize(
    "field, value",
    [
        ("max_velocity_scaling_factor", 0.0),
        ("max_velocity_scaling_factor", 1.5),
        ("max_acceleration_scaling_factor", float("nan")),
        ("max_acceleration_scaling_factor", -0.1),
        ("allowed_planning_time", 0.0),
    ],
)
def test_bad_scaling_or_time(mycobot, field, value):
    scene = PlanningScene(mycobot, ready(mycobot))
    request = MotionPlanRequest("arm", NamedGoal("home"))
    setattr(request, field, value)
    response = plan_joint_interpolation(scene, request)
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert field in response.message


def test_bad_max_step_and_goal_type(mycobot):
    scene = PlanningScene(mycobot, ready(mycobot))
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", NamedGoal("home")), max_step=-1.0)
    assert response.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    response = plan_joint_interpolation(scene, MotionPlanRequest("arm", "home"))
    assert response.error_code.val == MoveItErrorCode.UNRECOGNIZED_GOAL_TYPE


def test_start_state_of_another_robot(mycobot, panda):
    scene = PlanningScene(mycobot, ready(mycobot))
    request = MotionPlanRequest("arm", NamedGoal("home"), start_state=arm_state(panda, PANDA_READY))
    response = plan_joint_interpolation(scene, request)
    assert response.error_code.val == MoveItErrorCode.INVALID_ROBOT_STATE
