"""The OMPL pipeline on the myCobot and the Panda: goals reached, MoveIt error codes, seeds."""
from __future__ import annotations

import math

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core import PlanningScene, RobotModel, RobotState
from mycobot_planning.core.planners.ompl.planner_manager import OmplPlanner
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, NamedGoal, PoseGoal
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose

TAU = 2 * math.pi


@pytest.fixture(scope="module")
def planner() -> OmplPlanner:
    return OmplPlanner()


def fallback_scene(model: RobotModel, with_box: bool) -> PlanningScene:
    """The seeds' fallbacks_move_to case (c): a thin wall beside the arm."""
    scene = PlanningScene(model)
    if with_box:
        scene.add_object(
            CollisionObject.box("box", [0.005, 0.1, 0.32], make_pose([0.02, -0.20, 0.16]), frame_id="base_link")
        )
    return scene


def ready_with(model: RobotModel, **joints: float) -> RobotState:
    state = RobotState(model)
    state.set_named("ready")
    state.set_joint_positions(joints)
    return state


def assert_valid(scene: PlanningScene, response, group: str, start: RobotState) -> None:
    assert response.success, response.error_code
    report = validate_trajectory(scene, response.trajectory, group, start)
    assert report.valid, report.problems


def assert_ends_at_pose(start: RobotState, response, link: str, target: np.ndarray) -> None:
    """The arm's last trajectory point puts ``link`` at ``target``."""
    end = start.copy()
    end.set_group_positions("arm", response.trajectory.positions[-1])
    assert np.allclose(end.frame_pose(link), target, atol=1e-4)


@pytest.mark.parametrize("case", ["a", "b", "c"])
def test_fallback_cases_succeed(mycobot: RobotModel, planner: OmplPlanner, case: str):
    target = dict(mycobot.named_state("ready", "arm"), link1_to_link2=TAU / 8)
    start = {
        "a": ready_with(mycobot, link1_to_link2=-TAU / 8),
        "b": ready_with(mycobot, link1_to_link2=TAU / 8, link3_to_link4=0.0),
        "c": ready_with(mycobot, link1_to_link2=-TAU / 8),
    }[case]
    scene = fallback_scene(mycobot, with_box=case == "c")
    response = planner.plan(scene, MotionPlanRequest("arm", JointGoal(target), start_state=start, seed=3))
    assert_valid(scene, response, "arm", start)
    end = response.trajectory.positions[-1]
    assert np.allclose(end, [target[j] for j in mycobot.group("arm").joint_names], atol=1e-6)


def test_named_and_pose_goals(mycobot: RobotModel, planner: OmplPlanner):
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    named = planner.plan(scene, MotionPlanRequest("arm", NamedGoal("home"), start_state=start, seed=1))
    assert_valid(scene, named, "arm", start)
    target = make_pose([0.15, 0.05, 0.15], rpy=[math.pi, 0.0, 0.0])
    posed = planner.plan(scene, MotionPlanRequest("arm", PoseGoal(target), start_state=start, seed=1))
    assert_valid(scene, posed, "arm", start)
    assert_ends_at_pose(start, posed, "link6_flange", target)


def test_planner_ids(mycobot: RobotModel, planner: OmplPlanner):
    scene = fallback_scene(mycobot, with_box=False)
    start = ready_with(mycobot)
    for planner_id in ("RRTConnectkConfigDefault", "arm[RRTkConfigDefault]", "KPIECE", "geometric::BITstar"):
        response = planner.plan(
            scene, MotionPlanRequest("arm", NamedGoal("home"), start_state=start, planner_id=planner_id, seed=2)
        )
        assert_valid(scene, response, "arm", start)


def test_panda_pose_goal(panda: RobotModel, planner: OmplPlanner):
    scene = PlanningScene(panda)
    scene.add_object(CollisionObject.box("table", [0.6, 0.6, 0.04], make_pose([0.5, 0.0, -0.02])))
    start = RobotState(panda)
    start.set_named("default")
    target = start.frame_pose("panda_hand_tcp")
    target[:3, 3] += [0.05, 0.25, -0.15]
    response = planner.plan(scene, MotionPlanRequest("arm", PoseGoal(target), start_state=start, seed=4))
    assert_valid(scene, response, "arm", start)
    assert_ends_at_pose(start, response, "panda_hand_tcp", target)


def test_error_codes(mycobot: RobotModel, planner: OmplPlanner):
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)

    def plan(**kwargs):
        args = {"group": "arm", "goal": NamedGoal("home"), "start_state": start, "seed": 1}
        args.update(kwargs)
        return planner.plan(scene, MotionPlanRequest(**args))

    # 'ready' itself reaches into the wall: a goal in collision.
    inside_wall = ready_with(mycobot)
    assert scene.check_collision(inside_wall).collision
    code = plan(goal=JointGoal(inside_wall.group_positions("arm"))).error_code
    assert code.val == MoveItErrorCode.GOAL_IN_COLLISION and "box" in code.message
    assert plan(goal=PoseGoal(make_pose([0.9, 0.0, 0.2]))).error_code.val == MoveItErrorCode.NO_IK_SOLUTION
    code = plan(start_state=inside_wall).error_code
    assert code.val == MoveItErrorCode.START_STATE_IN_COLLISION and "contact between 'box' (Object)" in code.message
    assert plan(allowed_planning_time=1e-6, goal=JointGoal(dict(mycobot.named_state("ready", "arm"), link1_to_link2=TAU / 8))).error_code.val in (
        MoveItErrorCode.TIMED_OUT,
        MoveItErrorCode.PLANNING_FAILED,
    )
    assert plan(group="legs").error_code.val == MoveItErrorCode.INVALID_GROUP_NAME
    assert plan(planner_id="NoSuchPlanner").error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert plan(goal=JointGoal([math.nan] * 6)).error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    assert plan(goal=JointGoal([0.0] * 5)).error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    assert plan(goal=JointGoal([4.0] + [0.0] * 5)).error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    assert plan(goal=NamedGoal("dance")).error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    assert plan(max_velocity_scaling_factor=0.0).error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert plan(allowed_planning_time=-1.0).error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN
    assert plan(goal=PoseGoal(np.full((4, 4), np.nan))).error_code.val == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS
    assert plan(goal=PoseGoal(make_pose([0.1, 0, 0.2]), link="nowhere")).error_code.val == MoveItErrorCode.INVALID_LINK_NAME


def test_seeded_runs_are_reproducible(mycobot: RobotModel, planner: OmplPlanner):
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    goal = JointGoal(dict(mycobot.named_state("ready", "arm"), link1_to_link2=TAU / 8))
    a = planner.plan(scene, MotionPlanRequest("arm", goal, start_state=start, seed=11))
    b = planner.plan(scene, MotionPlanRequest("arm", goal, start_state=start, seed=11))
    assert a.success and b.success
    assert np.array_equal(a.path, b.path)


def test_velocity_scaling_slows_the_trajectory(mycobot: RobotModel, planner: OmplPlanner):
    scene = fallback_scene(mycobot, with_box=False)
    start = ready_with(mycobot)
    fast = planner.plan(scene, MotionPlanRequest("arm", NamedGoal("home"), start_state=start, seed=1))
    slow = planner.plan(
        scene,
        MotionPlanRequest(
            "arm", NamedGoal("home"), start_state=start, seed=1, max_velocity_scaling_factor=0.2, max_acceleration_scaling_factor=0.2
        ),
    )
    assert slow.trajectory.duration > 2 * fast.trajectory.duration
    assert np.max(np.abs(slow.trajectory.velocities)) <= 0.2 * 2.792527 + 1e-6


def test_no_path_crosses_the_thin_wall_between_checks(mycobot: RobotModel, planner: OmplPlanner):
    """OMPL checks edges every ~0.07 rad here; the planner re-checks the path densely and
    re-plans finer, so no seed may return a path through the 5 mm wall of case (c)."""
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    goal = JointGoal(dict(mycobot.named_state("ready", "arm"), link1_to_link2=TAU / 8))
    for seed in range(1, 41):
        response = planner.plan(scene, MotionPlanRequest("arm", goal, start_state=start, seed=seed))
        assert_valid(scene, response, "arm", start)


def test_the_response_says_the_trajectory_was_validated(mycobot: RobotModel, planner: OmplPlanner):
    """The OMPL pipeline runs the trajectory validator on what it returns, so task solvers skip
    a second pass: the flag must only be set on trajectories that do validate."""
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    goal = JointGoal(dict(mycobot.named_state("ready", "arm"), link1_to_link2=TAU / 8))
    response = planner.plan(scene, MotionPlanRequest("arm", goal, start_state=start, seed=5))
    assert response.validated
    assert_valid(scene, response, "arm", start)
    failed = planner.plan(scene, MotionPlanRequest("arm", JointGoal(ready_with(mycobot).group_positions("arm") + 9.0),
                                                   start_state=start, seed=5))
    assert not failed.success and not failed.validated


def test_collision_only_checker_agrees_with_the_full_check_within_limits(mycobot: RobotModel):
    scene = fallback_scene(mycobot, with_box=True)
    start = ready_with(mycobot)
    jmg = mycobot.group("arm")
    full_check = scene.validity_checker("arm", start)
    collision_only = scene.validity_checker("arm", start, check_bounds=False)
    rng = np.random.default_rng(0)
    lower, upper = mycobot.lower_limits[jmg.variable_indices], mycobot.upper_limits[jmg.variable_indices]
    verdicts = [(full_check(x), collision_only(x)) for x in rng.uniform(lower, upper, size=(300, len(lower)))]
    assert all(a == b for a, b in verdicts)
    assert any(a for a, _ in verdicts) and not all(a for a, _ in verdicts)
    # It follows later changes of the scene, like the full check: 'ready' reaches into the wall.
    inside_wall = ready_with(mycobot).group_positions("arm")
    assert not collision_only(inside_wall) and not full_check(inside_wall)
    scene.remove_object("box")
    assert collision_only(inside_wall) and full_check(inside_wall)


def test_a_free_straight_motion_is_the_plan_and_is_validated(mycobot: RobotModel, planner: OmplPlanner):
    """Without the wall the straight motion ready -> ready + tau/8 on joint 2 is free: the plan is
    that line (interpolated at the checking resolution), timed as one motion from rest to rest
    and still checked by the trajectory validator; with the wall the planner goes around."""
    start = ready_with(mycobot, link1_to_link2=-TAU / 8)
    goal = dict(mycobot.named_state("ready", "arm"), link1_to_link2=TAU / 8)
    scene = fallback_scene(mycobot, with_box=False)
    response = planner.plan(scene, MotionPlanRequest("arm", JointGoal(goal), start_state=start, seed=4))
    assert_valid(scene, response, "arm", start)
    assert response.validated
    path = response.path
    direction = path[-1] - path[0]
    offsets = (path - path[0]) @ direction / (direction @ direction)
    assert np.allclose(path, path[0] + offsets[:, None] * direction, atol=1e-9)  # on the line
    assert np.all(np.diff(offsets) > 0)
    speeds = np.abs(response.trajectory.velocities).max(axis=1)
    assert speeds[0] == pytest.approx(0.0, abs=1e-9) and speeds[-1] == pytest.approx(0.0, abs=1e-9)
    walled = fallback_scene(mycobot, with_box=True)
    around = planner.plan(walled, MotionPlanRequest("arm", JointGoal(goal), start_state=start, seed=4))
    assert_valid(walled, around, "arm", start)
    assert len(around.path) > 2
    bent = around.path - around.path[0]
    d = bent[-1]
    assert not np.allclose(bent, np.outer(bent @ d / (d @ d), d), atol=1e-3)  # not the straight line
