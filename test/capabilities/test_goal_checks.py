"""Goals refused instead of silently rewritten (issue 27), without ROS: moveit_msgs requests
through the moveit_msgs face's translation (moveit_translation) and the capabilities' one check
(check_goal / check_tolerance, which the JSON face uses too), constraints of IK and state
validity honoured, unknown names and internal errors answered with MoveItErrorCodes values."""
from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import Pose
from moveit_msgs.msg import Constraints, JointConstraint, MoveItErrorCodes, OrientationConstraint, PositionConstraint
from shape_msgs.msg import SolidPrimitive

from interfaces_py.msgs import MoveItErrorCode, RobotState as RobotStateMsg
from interfaces_py.ros_message_reading import ConversionError
from mycobot_planning.capabilities import cartesian_path, kinematics, plan, state_validation
from mycobot_planning.capabilities.move_group_context import RequestError, check_goal
from mycobot_planning.core.planning_interface.planning_interface import JointGoal, MotionPlanRequest, PoseGoal
from mycobot_planning.core.planning_interface.planning_pipeline import PlanningPipeline
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_planning.ros.move_group.moveit_translation import cartesian_request_from_msg, goal_from_constraints
from test_request_budgets import ARM, _core

GOAL = [1.0, -1.0, -0.8, 0.3, 0.5, 0.8]
C = MoveItErrorCodes


@pytest.fixture(scope="module")
def core(mycobot):
    return _core(mycobot, PlanningPipeline())


def _joints(*entries) -> Constraints:
    return Constraints(joint_constraints=[JointConstraint(joint_name=j, position=p, tolerance_above=above,
                                                          tolerance_below=below, weight=1.0)
                                          for j, p, above, below in entries])


def _pose_goal(primitives, poses=1, orientation_tolerance=0.1) -> Constraints:
    pc = PositionConstraint(link_name="link6_flange")
    pc.constraint_region.primitives = [SolidPrimitive(type=t, dimensions=d) for t, d in primitives]
    pc.constraint_region.primitive_poses = [Pose() for _ in range(poses)]
    for p in pc.constraint_region.primitive_poses:
        p.position.x, p.position.z, p.orientation.w = 0.15, 0.2, 1.0
    oc = OrientationConstraint(link_name="link6_flange", absolute_x_axis_tolerance=orientation_tolerance,
                               absolute_y_axis_tolerance=0.1, absolute_z_axis_tolerance=0.1)
    oc.orientation.w = 1.0
    return Constraints(position_constraints=[pc], orientation_constraints=[oc])


@pytest.mark.parametrize("constraints, words", [
    (_joints(("link1_to_link2", 0.5, math.nan, 0.0)), "tolerance_above"),
    (_joints(("link1_to_link2", 0.5, 0.01, -0.1)), "must not be negative"),
    (_joints(("link1_to_link2", 0.5, 0.01, 0.01), ("link1_to_link2", -0.5, 0.01, 0.01)), "constrained twice"),
    (_pose_goal([(SolidPrimitive.BOX, [0.1, -0.1, 0.1])]), "no volume"),
    (_pose_goal([(SolidPrimitive.SPHERE, [])]), "no volume"),
    (_pose_goal([], poses=0), "no primitive"),
    (_pose_goal([(SolidPrimitive.SPHERE, [0.01]), (SolidPrimitive.SPHERE, [0.02])], poses=1), "2 primitives but 1"),
    (_pose_goal([(SolidPrimitive.SPHERE, [0.01])], orientation_tolerance=math.nan), "absolute_x_axis_tolerance"),
    (_pose_goal([(SolidPrimitive.SPHERE, [0.01])], orientation_tolerance=-0.1), "must not be negative"),
])
def test_bad_goal_constraints_are_refused_not_rewritten(constraints, words):
    with pytest.raises(ConversionError) as caught:
        goal_from_constraints(constraints)
    assert caught.value.code == C.INVALID_GOAL_CONSTRAINTS
    assert words in caught.value.message


def test_good_goal_constraints_still_translate():
    goal, frame = goal_from_constraints(_joints(("link1_to_link2", 0.5, 0.0, 0.0), ("link1_to_link2", 0.5, 0.01, 0.0)))
    assert isinstance(goal, JointGoal) and goal.values == {"link1_to_link2": 0.5} and goal.tolerance == 0.01
    goal, _ = goal_from_constraints(_pose_goal([(SolidPrimitive.BOX, [0.02, 0.04, 0.06])]))
    assert isinstance(goal, PoseGoal) and goal.position_tolerance == pytest.approx(0.01)


@pytest.mark.parametrize("goal, words", [
    (JointGoal({"link1_to_link2": 0.5}, math.nan), "goal tolerance"),
    (JointGoal({"link1_to_link2": 0.5}, -1e-3), "must not be negative"),
    (JointGoal({"nojoint": 0.5}), "does not have"),
    (JointGoal({"link1_to_link2": math.inf}), "finite"),
    (PoseGoal(np.eye(4), orientation_tolerance=math.nan), "orientation tolerance"),
])
def test_check_goal_refuses_what_either_face_could_send(mycobot, goal, words):
    with pytest.raises(RequestError) as caught:
        check_goal(mycobot, goal)
    assert caught.value.code == MoveItErrorCode.INVALID_GOAL_CONSTRAINTS and words in caught.value.message


def test_a_planner_id_the_pipeline_does_not_offer_is_refused(core):
    request = MotionPlanRequest("arm", JointGoal(dict(zip(ARM, GOAL)), 1e-3), pipeline_id="joint_interpolation",
                                planner_id="PTP")
    result = plan.plan(core, request)
    assert result.error_code.val == MoveItErrorCode.INVALID_MOTION_PLAN and "PTP" in result.error_code.message
    # without a planner id, another pipeline than the default plans with its own planner
    request = MotionPlanRequest("arm", JointGoal(dict(zip(ARM, GOAL)), 1e-3), pipeline_id="joint_interpolation")
    assert plan.plan(core, request).error_code.val == MoveItErrorCode.SUCCESS


@pytest.mark.parametrize("max_step", [0.0, -0.01, math.nan])
def test_cartesian_max_step_not_positive_is_failure_as_in_moveit(core, max_step):
    from moveit_msgs.srv import GetCartesianPath

    msg = GetCartesianPath.Request(group_name="arm", max_step=max_step)
    pose = Pose()
    pose.position.x, pose.position.z, pose.orientation.w = 0.15, 0.2, 1.0
    msg.waypoints = [pose]
    result = cartesian_path.compute_cartesian_path(core, cartesian_request_from_msg(msg))
    expected = MoveItErrorCode.FAILURE if not math.isnan(max_step) else MoveItErrorCode.INVALID_MOTION_PLAN
    assert result.error_code.val == expected and result.trajectory is None


def _flange(mycobot, values) -> np.ndarray:
    state = RobotState(mycobot)
    state.set_joint_positions(dict(zip(ARM, values)))
    return state.frame_pose("link6_flange")


def test_check_state_validity_evaluates_its_constraints(core):
    state = RobotStateMsg(joint_names=list(ARM), positions=[0.0] * 6)
    inside = {"joints": [{"joint": "link1_to_link2", "position": 0.0, "above": 0.1, "below": 0.1}],
              "orientation": [], "position": []}
    outside = {"joints": [{"joint": "link1_to_link2", "position": 1.0, "above": 0.1, "below": 0.1}],
               "orientation": [], "position": []}
    code, answer = state_validation.check_state_validity(core, state, "arm", inside)
    assert code.val == MoveItErrorCode.SUCCESS and answer.valid and answer.constraint_results == [(True, 0.0)]
    code, answer = state_validation.check_state_validity(core, state, "arm", outside)
    assert code.val == MoveItErrorCode.SUCCESS and not answer.valid
    assert answer.constraint_results[0][0] is False and answer.constraint_results[0][1] == pytest.approx(0.9)


def test_compute_ik_honours_its_constraints(core, mycobot):
    target = _flange(mycobot, GOAL)
    bad = {"joints": [{"joint": "link1_to_link2", "position": math.nan, "above": 0.1, "below": 0.1}],
           "orientation": [], "position": []}
    code, state = kinematics.compute_ik(core, "arm", target, constraints=bad)
    assert code.val != MoveItErrorCode.SUCCESS and state is None and code.val != MoveItErrorCode.FAILURE
    # a joint window that excludes every solution: no IK solution, never one outside it
    impossible = {"joints": [{"joint": "link1_to_link2", "position": GOAL[0] + 2.0, "above": 0.01, "below": 0.01}],
                  "orientation": [], "position": []}
    code, state = kinematics.compute_ik(core, "arm", target, timeout=0.2, constraints=impossible)
    assert code.val == MoveItErrorCode.NO_IK_SOLUTION and state is None
    window = {"joints": [{"joint": "link1_to_link2", "position": GOAL[0], "above": 0.05, "below": 0.05}],
              "orientation": [], "position": []}
    code, state = kinematics.compute_ik(core, "arm", target, constraints=window)
    assert code.val == MoveItErrorCode.SUCCESS and abs(state.joint_position("link1_to_link2") - GOAL[0]) <= 0.05 + 1e-9


def test_internal_errors_a_client_can_reach_are_moveit_codes(core, mycobot):
    code, _ = kinematics.compute_ik(core, "arm", _flange(mycobot, GOAL), timeout=2.0 ** 31 - 1)
    assert MoveItErrorCode.is_known(code.val) and code.val != MoveItErrorCode.FAILURE and "timeout" in code.message
    code, answer = state_validation.check_state_validity(core, RobotStateMsg(joint_names=["nojoint"], positions=[0.0]))
    assert code.val == MoveItErrorCode.INVALID_ROBOT_STATE and "nojoint" in code.message and not answer.valid
    code, _ = kinematics.compute_ik(core, "arm", _flange(mycobot, GOAL),
                                    seed=RobotStateMsg(joint_names=["link1_to_link2"], positions=[1e308]))
    assert code.val == MoveItErrorCode.INVALID_ROBOT_STATE


def test_a_task_solution_whose_diff_names_an_unknown_object_in_the_acm_is_applied_with_a_warning(core):
    """MTC's solutions carry the task's whole collision matrix, naming objects the task knew even
    when they are gone (mtc_node with spawn_table false still names the table): applied as
    move_group applies them, with a warning naming the unknown entries."""
    from mycobot_planning.capabilities import task_solution
    from mycobot_planning.core.trajectory_execution import parse_task_solution

    said: list[str] = []
    core._log = lambda level, text: said.append(text)
    ghost = {"is_diff": True, "allowed_collision_matrix": {"entry_names": ["ghost", "link1"],
                                                           "entry_values": [[False, True], [True, False]]}}
    from interfaces_py.msgs import CollisionObject
    from mycobot_planning.core.transforms import make_pose

    box = CollisionObject.box("cube", [0.02, 0.02, 0.02], make_pose([0.2, 0.0, 0.1])).to_dict()
    steps = parse_task_solution({"steps": [{"name": "add", "scene_diff_after": {"is_diff": True,
                                                                               "world": {"collision_objects": [box]}}},
                                           {"name": "named", "scene_diff_after": ghost}]})
    result = task_solution.execute_task_solution(core, steps)
    assert result.success, result.error_code.message
    assert any("'ghost'" in text and "applied as it is" in text for text in said)
    assert "cube" in [o.id for o in core.scene_msg().world.collision_objects]
    # an entry for an object an earlier step adds is fine
    fine = {"is_diff": True, "allowed_collision_matrix": {"entry_names": ["cube", "link1"],
                                                          "entry_values": [[False, True], [True, False]]}}
    assert core.unknown_acm_names(parse_task_solution({"steps": [{"name": "s", "scene_diff_after": fine}]})[0]
                                  .scene_diff_after, {"cube"}) == []


def test_accelerations_without_velocities_are_refused_before_any_controller(mycobot):
    from interfaces_py.msgs import JointTrajectory, JointTrajectoryPoint
    from mycobot_planning.core.trajectory_execution import ExecutionError
    from mycobot_planning.core.trajectory_execution.trajectory_preparation import prepare_trajectory

    trajectory = JointTrajectory(list(ARM), [JointTrajectoryPoint([0.0] * 6, [], [0.0] * 6, 0.0),
                                             JointTrajectoryPoint([0.1] + [0.0] * 5, [], [0.0] * 6, 1.0)])
    with pytest.raises(ExecutionError, match="accelerations but no velocities"):
        prepare_trajectory(mycobot, trajectory)


def test_meshes_beyond_the_documented_budget_are_refused():
    from interfaces_py.msgs import MAX_MESH_TRIANGLES, MAX_MESH_VERTICES, MessageError
    from interfaces_py.msgs.geometry import Mesh

    assert MAX_MESH_VERTICES == 100_000 and MAX_MESH_TRIANGLES == 200_000
    Mesh(vertices=[[0.0, 0.0, 0.0]] * MAX_MESH_VERTICES, triangles=[[0, 1, 2]])
    with pytest.raises(MessageError, match="at most"):
        Mesh(vertices=[[0.0, 0.0, 0.0]] * (MAX_MESH_VERTICES + 1), triangles=[[0, 1, 2]])
