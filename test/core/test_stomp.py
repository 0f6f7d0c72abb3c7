"""STOMP as the "stomp" planning pipeline (MoveIt's stomp_moveit): it optimises the straight line
around an obstacle, its paths are judged by the trajectory validator's plain check of every pair
at the validator's dense resolution, pose goals go through IK, an exhausted budget is TIMED_OUT,
parameters out of range are refused, a seed makes it repeatable, and it is selectable wherever a
pipeline is (the registry, the JSON face, MTC's PipelinePlanner)."""
from __future__ import annotations

import functools
import time

import numpy as np
import pytest

from interfaces_py.msgs import CollisionObject, MoveItErrorCode
from mycobot_planning.core.kinematic_constraints.kinematic_constraints import path_constraints_from_json
from mycobot_planning.core.kinematics.ik_solver import solve_ik
from mycobot_planning.core.planners.stomp import DEFAULT_PARAMS, StompParams, StompPlanner
from mycobot_planning.core.planning_interface.planning_interface import (
    JointGoal,
    MotionPlanRequest,
    NamedGoal,
)
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.trajectory_processing.trajectory_validator import validate_trajectory
from mycobot_planning.core.transforms import make_pose
from trajectory_optimizer_testing import (
    BUDGET_S,
    LEFT,
    RIGHT,
    TIP,
    arm_state,
    assert_listed_and_selectable,
    assert_parameters_refused,
    assert_plain_valid,
    boxed_scene,
    optimizer_request,
)

DOWN = [0.0, 1.0, 0.0, 0.0]  # the flange's z axis along -world z


@pytest.fixture(scope="module")
def boxed(mycobot):
    return boxed_scene(mycobot)


stomp_request = functools.partial(optimizer_request, "stomp")


def test_a_joint_goal_around_a_box(pipeline, boxed):
    scene, start = boxed
    straight = pipeline.plan(scene, MotionPlanRequest("arm", JointGoal(RIGHT), start_state=start,
                                                      pipeline_id="joint_interpolation"))
    assert straight.error_code.val == MoveItErrorCode.PLANNING_FAILED and "box" in straight.message
    started = time.perf_counter()
    response = pipeline.plan(scene, stomp_request(JointGoal(RIGHT), start, planner_id="STOMP"))
    elapsed = time.perf_counter() - started
    assert_plain_valid(scene, response, start)
    assert response.validated and response.planner_id == "stomp" and response.group_name == "arm"
    assert len(response.path) == DEFAULT_PARAMS.num_timesteps
    trajectory = response.trajectory
    assert np.allclose(trajectory.positions[0], LEFT) and np.allclose(trajectory.positions[-1], RIGHT, atol=1e-6)
    assert elapsed < BUDGET_S
    # the path went around: some waypoint left the straight line
    line = LEFT + np.linspace(0, 1, len(response.path))[:, None] * (RIGHT - LEFT)
    assert np.max(np.abs(response.path - line)) > 0.05


def test_lowercase_planner_id_and_named_goal(pipeline, mycobot):
    start = arm_state(mycobot, LEFT)
    scene = PlanningScene(mycobot, start)
    response = pipeline.plan(scene, stomp_request(NamedGoal("home"), start, planner_id="stomp"))
    assert_plain_valid(scene, response, start)
    assert "straight line is valid" in response.message  # nothing in the way: no iteration needed
    refused = pipeline.plan(scene, stomp_request(NamedGoal("home"), start, planner_id="RRTConnectkConfigDefault"))
    assert refused.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "STOMP" in refused.message


def test_a_fixed_seed_gives_the_same_path(pipeline, boxed):
    scene, start = boxed
    first = pipeline.plan(scene, stomp_request(JointGoal(RIGHT), start, seed=7))
    second = pipeline.plan(scene, stomp_request(JointGoal(RIGHT), start, seed=7))
    assert first.success and second.success
    assert np.array_equal(first.path, second.path)


def test_a_tiny_budget_times_out_and_too_few_iterations_fail(pipeline, boxed):
    scene, start = boxed
    response = pipeline.plan(scene, stomp_request(JointGoal(RIGHT), start, seed=4, allowed_planning_time=0.005))
    assert response.error_code.val == MoveItErrorCode.TIMED_OUT, response.error_code
    assert response.trajectory is None
    planner = StompPlanner({"num_iterations": "1"})
    response = planner.plan(scene, stomp_request(JointGoal(RIGHT), start, seed=4))
    assert response.error_code.val == MoveItErrorCode.PLANNING_FAILED and "num_iterations" in response.message


@pytest.mark.parametrize("params, words", [
    ({"num_timesteps": "2"}, "num_timesteps must be >= 3"),
    ({"num_iterations": "0"}, "num_iterations must be >= 1"),
    ({"num_iterations_after_valid": "-1"}, "num_iterations_after_valid must be >= 0"),
    ({"num_rollouts": "0"}, "num_rollouts must be >= 1"),
    ({"num_rollouts": "30"}, "max_rollouts must be >= num_rollouts (30)"),
    ({"exponentiated_cost_sensitivity": "-0.5"}, "exponentiated_cost_sensitivity must be >= 0"),
    ({"control_cost_weight": "-1"}, "control_cost_weight must be >= 0"),
    ({"delta_t": "0"}, "delta_t must be > 0"),
    ({"delta_t": "nan"}, "delta_t must be a finite number"),
    ({"num_timesteps": "4.5"}, "num_timesteps must be an integer"),
    ({"num_rollouts": "many"}, "num_rollouts must be a number"),
    ({"num_timesteps": "50", "speed": "1"}, "unknown STOMP parameters ['speed']"),
])
def test_parameters_out_of_range_are_refused(params, words):
    assert_parameters_refused(StompPlanner, "STOMP", params, words)


def test_parameters_have_moveits_defaults_and_can_be_set():
    planner = StompPlanner()
    assert planner.planner_params("STOMP") == {
        "num_timesteps": "40", "num_iterations": "1000", "num_iterations_after_valid": "0", "num_rollouts": "15",
        "max_rollouts": "25", "exponentiated_cost_sensitivity": "0.5", "control_cost_weight": "0.1",
        "delta_t": "0.1"}
    assert planner.set_planner_params("stomp", {"num_timesteps": "60", "num_rollouts": "30", "max_rollouts": "30"}) is None
    assert planner.params == StompParams(num_timesteps=60, num_rollouts=30, max_rollouts=30)
    assert planner.set_planner_params("STOMP", {"num_iterations": "40"}, replace=True) is None
    assert planner.params == StompParams(num_iterations=40)
    assert planner.set_planner_params("PTP", {"num_iterations": "40"}) is not None
    assert planner.planner_params("PTP") == {}


def test_listed_and_selectable_where_pipelines_are(mycobot, pipeline):
    assert_listed_and_selectable(mycobot, pipeline, "stomp", "STOMP", "num_timesteps", "40", {"num_rollouts": "0"},
                                 "num_rollouts must be >= 1")


def test_path_constraints_are_kept(pipeline, mycobot):
    """The flange keeps pointing down (0.1 rad) on a motion whose straight line self-collides."""
    scene = PlanningScene(mycobot)
    start = solve_ik(mycobot, "arm", make_pose([0.15, 0.05, 0.25], quat_xyzw=DOWN), seed=RobotState(mycobot),
                     scene=scene, timeout=1.0, rng=0)[0]
    goal = solve_ik(mycobot, "arm", make_pose([0.0, 0.2, 0.2], quat_xyzw=DOWN), seed=start, scene=scene,
                    timeout=1.0, rng=0)[0]
    scene.set_current_state(start)
    constraints = path_constraints_from_json(
        {"orientation": [{"link": TIP, "orientation": DOWN, "tolerance": [0.1, 0.1, np.pi]}]}, start,
        lambda frame: np.eye(4))
    goal_vector = goal.group_positions("arm")
    response = pipeline.plan(scene, stomp_request(JointGoal(goal_vector), start, path_constraints=constraints))
    assert_plain_valid(scene, response, start)
    for q in response.trajectory.positions:  # checked here with plain geometry: the tilt of the z axis
        z = arm_state(mycobot, q).frame_pose(TIP)[:3, 2]
        assert np.arccos(np.clip(-z[2], -1.0, 1.0)) <= 0.1 * np.sqrt(2) + 1e-6


def test_the_manifold_values_of_many_states_are_those_of_each(mycobot):
    """ConstraintManifold.values_many (STOMP's rollout cost) gives value() row by row, for joint,
    orientation (both parameterizations) and box / sphere / cylinder position rows."""
    from mycobot_planning.core.kinematic_constraints.constraint_manifold import ConstraintManifold

    start = RobotState(mycobot)
    regions = [{"type": kind, "dimensions": dims, "pose": {"position": [0.1, 0.0, 0.2]}}
               for kind, dims in (("box", [0.2, 0.1, 0.3]), ("sphere", [0.15]), ("cylinder", [0.2, 0.1]))]
    constraints = path_constraints_from_json({
        "joints": [{"joint": "link1_to_link2", "position": 0.0, "above": 0.3, "below": 0.3}],
        "orientation": [{"link": TIP, "orientation": DOWN, "tolerance": [0.2, 0.3, 0.4]},
                        {"link": "link5", "orientation": [0, 0, 0, 1], "tolerance": [0.5, 0.5, 0.5],
                         "parameterization": 1}],
        "position": [{"link": TIP, "regions": [region]} for region in regions],
    }, start, lambda frame: np.eye(4))
    manifold = ConstraintManifold(constraints, start, "arm")
    rows = np.random.default_rng(3).uniform(-1.5, 1.5, (50, 6))
    many = manifold.values_many(rows)
    assert many.shape == (50, manifold.codim) and np.count_nonzero(many) > 50
    assert np.allclose(many, [manifold.value(x) for x in rows], atol=1e-9)


def test_cancel_and_iterations_after_valid(boxed):
    import threading

    scene, start = boxed
    cancel = threading.Event()
    cancel.set()
    response = StompPlanner().plan(scene, stomp_request(JointGoal(RIGHT), start, cancel=cancel))
    assert response.error_code.val == MoveItErrorCode.PREEMPTED
    first = StompPlanner().plan(scene, stomp_request(JointGoal(RIGHT), start, seed=3))
    more = StompPlanner({"num_iterations_after_valid": 5}).plan(scene, stomp_request(JointGoal(RIGHT), start, seed=3))
    assert_plain_valid(scene, first, start)
    assert_plain_valid(scene, more, start)
    iterations = [int(r.message.split("valid after ")[1].split()[0]) for r in (first, more)]
    assert iterations[1] >= iterations[0] + 5


def test_the_panda_around_a_box(panda, pipeline):
    """Any URDF + SRDF robot: the Panda's 7 joints swing past a box on the straight line's path."""
    a = np.array([-1.2, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
    b = a.copy()
    b[0] = 1.2
    start = RobotState(panda)
    start.set_group_positions("arm", a)
    middle = RobotState(panda)
    middle.set_group_positions("arm", (a + b) / 2)
    scene = PlanningScene(panda, start)
    scene.add_object(CollisionObject.box("box", [0.08] * 3, make_pose(middle.frame_pose(panda.group("arm").tip_link)[:3, 3])))
    response = pipeline.plan(scene, stomp_request(JointGoal(b), start))
    assert response.success, response.error_code.message
    assert "straight line is valid" not in response.message
    assert validate_trajectory(scene, response.trajectory, "arm", start_state=start).valid
