"""Path constraints as MoveIt's kinematic constraints decide them, honoured by OMPL, checked on
the industrial planner's and joint interpolation's paths, and stopping Cartesian paths; every
planned state is checked here independently (scipy rotations, plain geometry)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from interfaces_py.msgs import MoveItErrorCode
from mycobot_planning.core.planners.cartesian.cartesian_path import STOP_PATH_CONSTRAINTS, compute_cartesian_path
from mycobot_planning.core.kinematic_constraints.kinematic_constraints import (
    ConstraintError,
    PathConstraints,
    path_constraints_from_json,
)
from mycobot_planning.core.kinematics.ik_solver import solve_ik
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.planning_scene.planning_scene import PlanningScene
from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.core.transforms import make_pose

TIP = "link6_flange"
DOWN = [0.0, 1.0, 0.0, 0.0]  # the flange's z axis along -world z


@pytest.fixture(scope="module")
def setup():
    model = RobotModel.mycobot()
    scene = PlanningScene(model)
    start = solve_ik(model, "arm", make_pose([0.15, 0.05, 0.25], quat_xyzw=DOWN), seed=RobotState(model),
                     scene=scene, timeout=1.0, rng=0)[0]
    goal = solve_ik(model, "arm", make_pose([0.17, -0.04, 0.2], quat_xyzw=DOWN), seed=start, scene=scene,
                    timeout=1.0, rng=0)[0]
    scene.set_current_state(start)
    return model, scene, start, goal, PlanningPipeline()


def keep_down(model: RobotModel, start: RobotState, tolerance: float = 0.1) -> PathConstraints:
    return path_constraints_from_json(
        {"orientation": [{"link": TIP, "orientation": DOWN, "tolerance": [tolerance, tolerance, np.pi]}]},
        start, lambda frame: np.eye(4))


def tilt(model: RobotModel, positions: np.ndarray, joint_names) -> float:
    """Angle between the flange's z axis and -world z (independent of the code under test)."""
    state = RobotState(model)
    state.set_joint_positions(dict(zip(joint_names, positions)))
    z = state.frame_pose(TIP)[:3, 2]
    return float(np.arccos(np.clip(-z[2], -1.0, 1.0)))


def request(goal: RobotState, constraints, pipeline: str = "ompl", planner: str = "") -> MotionPlanRequest:
    return MotionPlanRequest(group="arm", goal=JointGoal(list(goal.group_positions("arm"))), pipeline_id=pipeline,
                             planner_id=planner, allowed_planning_time=10.0, path_constraints=constraints, seed=3)


def test_ompl_keeps_the_orientation_along_the_whole_path(setup):
    model, scene, start, goal, pipeline = setup
    constraints = keep_down(model, start)
    response = pipeline.plan(scene, request(goal, constraints))
    assert response.success, response.error_code.message
    trajectory = response.trajectory
    tilts = [tilt(model, q, trajectory.joint_names) for q in trajectory.positions]
    # x and y tolerances of 0.1 rad (XYZ Euler) bound the tilt of the z axis by about 0.1 * sqrt(2)
    assert max(tilts) <= 0.1 * np.sqrt(2) + 1e-6
    assert np.allclose(trajectory.positions[-1], goal.group_positions("arm"), atol=1e-3)


def test_start_and_goal_that_break_the_constraints(setup):
    model, scene, start, goal, pipeline = setup
    tilted = goal.copy()
    tilted.set_joint_positions({"link5_to_link6": goal.joint_position("link5_to_link6") + 0.6})
    response = pipeline.plan(scene, request(tilted, keep_down(model, start)))
    assert response.error_code.val == MoveItErrorCode.GOAL_VIOLATES_PATH_CONSTRAINTS
    away = scene.copy()
    away.set_current_state(tilted)
    response = pipeline.plan(away, request(goal, keep_down(model, start)))
    assert response.error_code.val == MoveItErrorCode.START_STATE_VIOLATES_PATH_CONSTRAINTS
    assert "orientation of link6_flange" in response.error_code.message


def test_position_constraint_box(setup):
    model, scene, start, goal, pipeline = setup
    low, high = np.array([0.10, -0.08, 0.15]), np.array([0.22, 0.10, 0.30])
    box = {"type": "box", "dimensions": (high - low).tolist(),
           "pose": {"position": ((low + high) / 2).tolist(), "orientation": [0, 0, 0, 1]}}
    constraints = path_constraints_from_json({"position": [{"link": TIP, "regions": [box]}]}, start,
                                             lambda frame: np.eye(4))
    response = pipeline.plan(scene, request(goal, constraints))
    assert response.success, response.error_code.message
    for q in response.trajectory.positions:
        state = RobotState(model)
        state.set_joint_positions(dict(zip(response.trajectory.joint_names, q)))
        point = state.frame_pose(TIP)[:3, 3]
        assert np.all(point >= low - 1e-6) and np.all(point <= high + 1e-6)


def test_industrial_paths_are_checked(setup):
    model, scene, start, goal, pipeline = setup
    # the flange must stay within 3 cm of where it starts or of where it ends: both ends do, the
    # joint-interpolated PTP path between them (7 cm apart) does not
    ends = [state.frame_pose(TIP)[:3, 3] for state in (start, goal)]
    assert np.linalg.norm(ends[0] - ends[1]) > 0.06
    spheres = [{"type": "sphere", "dimensions": [0.03], "pose": {"position": p.tolist(), "orientation": [0, 0, 0, 1]}}
               for p in ends]
    constraints = path_constraints_from_json({"position": [{"link": TIP, "regions": spheres}]}, start,
                                             lambda frame: np.eye(4))
    ptp = pipeline.plan(scene, request(goal, constraints, "pilz_industrial_motion_planner", "PTP"))
    assert ptp.error_code.val == MoveItErrorCode.PLANNING_FAILED, ptp.error_code.message
    assert "the path at t =" in ptp.error_code.message and "left its constraint region" in ptp.error_code.message
    unconstrained = pipeline.plan(scene, request(goal, None, "pilz_industrial_motion_planner", "PTP"))
    assert unconstrained.success


def test_cartesian_path_stops_where_the_constraint_breaks(setup):
    model, scene, _, start, pipeline = setup  # from the goal state: clear of the arm itself
    scene = scene.copy()
    scene.set_current_state(start)
    begin = start.frame_pose(TIP)
    level = begin.copy()
    level[:3, 3] += [0.0, 0.0, -0.04]
    ok = compute_cartesian_path(scene, "arm", start, [level], eef_step=0.005,
                                path_constraints=keep_down(model, start, 0.05))
    assert ok.fraction == pytest.approx(1.0) and ok.stop_reason == "complete", ok.message
    tilted = level.copy()
    tilted[:3, :3] = begin[:3, :3] @ Rotation.from_euler("x", 0.4).as_matrix()
    stopped = compute_cartesian_path(scene, "arm", start, [tilted], eef_step=0.005,
                                     path_constraints=keep_down(model, start, 0.15))
    assert stopped.stop_reason == STOP_PATH_CONSTRAINTS
    assert 0.2 < stopped.fraction < 0.6  # the tilt grows evenly to 0.4 rad; 0.15 is passed at about 3/8
    assert "violates the path constraints" in stopped.message


def test_bad_constraints_are_refused(setup):
    model, scene, start, goal, pipeline = setup
    with pytest.raises(ConstraintError, match="unknown link"):
        path_constraints_from_json({"orientation": [{"link": "nope", "orientation": DOWN, "tolerance": [1, 1, 1]}]},
                                   start, lambda frame: np.eye(4))
    with pytest.raises(ConstraintError, match="3 tolerances"):
        path_constraints_from_json({"orientation": [{"link": TIP, "orientation": DOWN, "tolerance": [1]}]},
                                   start, lambda frame: np.eye(4))
    with pytest.raises(ConstraintError, match="region"):
        path_constraints_from_json({"position": [{"link": TIP, "regions": [{"type": "box", "dimensions": [1]}]}]},
                                   start, lambda frame: np.eye(4))
