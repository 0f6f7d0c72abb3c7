"""MoveIt's face as strict as the JSON face (issue 27), through the real moveit_msgs types:
goals that change nothing when they fail, refusals with MoveItErrorCodes values (never 99999,
never a traceback), cancels that stop planning. planning_server + mock_controllers run in real
processes (one bring-up for the module)."""
from __future__ import annotations

import math

import pytest
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import Pose
from shape_msgs.msg import SolidPrimitive
from moveit_msgs.action import MoveGroup
from moveit_msgs.msg import Constraints, JointConstraint, LinkPadding, LinkScale, PlannerParams, PositionConstraint
from moveit_msgs.srv import (
    ApplyPlanningScene,
    GetCartesianPath,
    GetMotionPlan,
    GetPlannerParams,
    GetPositionIK,
    GetStateValidity,
    SetPlannerParams,
)

from mycobot_planning.core.robot_model.robot_model import RobotModel
from mycobot_planning.core.robot_state.robot_state import RobotState
from mycobot_arm import ARM, READY
from ros_testing import wait_until
from test_move_group_api import FAR, C, Client, box, joint_goal, move_group_client, world_ids


@pytest.fixture(scope="module")
def client():
    with move_group_client() as user:
        yield user


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


# ----------------------------------------------------------------------------- refused, not rewritten
def test_goals_are_refused_instead_of_rewritten(client: Client) -> None:
    request = joint_goal(FAR)
    request.motion_plan_request.goal_constraints[0].joint_constraints[0].tolerance_above = math.nan
    response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert response.error_code.val == C.INVALID_GOAL_CONSTRAINTS and "tolerance_above" in response.error_code.message
    request = joint_goal(FAR)
    request.motion_plan_request.pipeline_id = "joint_interpolation"
    request.motion_plan_request.planner_id = "PTP"
    response = client.call(GetMotionPlan, "/plan_kinematic_path", request).motion_plan_response
    assert response.error_code.val == C.INVALID_MOTION_PLAN and "PTP" in response.error_code.message
    cartesian = GetCartesianPath.Request(group_name="arm", max_step=0.0)
    cartesian.waypoints = [Pose()]
    cartesian.waypoints[0].position.x, cartesian.waypoints[0].position.z = 0.15, 0.2
    cartesian.waypoints[0].orientation.w = 1.0
    answer = client.call(GetCartesianPath, "/compute_cartesian_path", cartesian)
    assert answer.error_code.val == C.FAILURE and "max_step" in answer.error_code.message  # as MoveIt


def test_state_validity_and_ik_honour_their_constraints(client: Client) -> None:
    request = GetStateValidity.Request(group_name="arm")
    request.robot_state.joint_state.name = list(ARM)
    request.robot_state.joint_state.position = [0.0] * 6
    request.constraints = Constraints(joint_constraints=[JointConstraint(
        joint_name=ARM[0], position=1.0, tolerance_above=0.1, tolerance_below=0.1, weight=1.0)])
    answer = client.call(GetStateValidity, "/check_state_validity", request)
    assert not answer.valid and [r.result for r in answer.constraint_result] == [False]
    assert answer.constraint_result[0].distance == pytest.approx(0.9)
    ik = GetPositionIK.Request()
    ik.ik_request.group_name = "arm"
    ik.ik_request.pose_stamped.header.frame_id = "world"
    ik.ik_request.pose_stamped.pose.position.x, ik.ik_request.pose_stamped.pose.position.z = 0.15, 0.2
    ik.ik_request.pose_stamped.pose.orientation.w = 1.0
    ik.ik_request.constraints = Constraints(joint_constraints=[JointConstraint(
        joint_name=ARM[0], position=math.nan, tolerance_above=0.1, tolerance_below=0.1, weight=1.0)])
    answer = client.call(GetPositionIK, "/compute_ik", ik)
    assert answer.error_code.val not in (C.SUCCESS, C.FAILURE), answer.error_code.message


def test_internal_errors_become_moveit_error_codes(client: Client) -> None:
    ik = GetPositionIK.Request()
    ik.ik_request.group_name = "arm"
    ik.ik_request.pose_stamped.pose.orientation.w = 1.0
    ik.ik_request.timeout.sec = 2 ** 31 - 1
    answer = client.call(GetPositionIK, "/compute_ik", ik)
    assert answer.error_code.val not in (C.SUCCESS, C.FAILURE) and "timeout" in answer.error_code.message
    request = GetStateValidity.Request(group_name="arm")
    request.robot_state.joint_state.name = ["nojoint"]
    request.robot_state.joint_state.position = [0.0]
    answer = client.call(GetStateValidity, "/check_state_validity", request)
    assert not answer.valid
    scene = ApplyPlanningScene.Request()
    scene.scene.is_diff = True
    scene.scene.robot_state.is_diff = True
    scene.scene.link_padding = [LinkPadding(link_name="nolink", padding=math.nan)]
    assert not client.call(ApplyPlanningScene, "/apply_planning_scene", scene).success
    scene.scene.link_padding = []
    scene.scene.link_scale = [LinkScale(link_name="link2", scale=-1.0)]
    assert not client.call(ApplyPlanningScene, "/apply_planning_scene", scene).success
    log = client.server.output()
    assert "Traceback" not in log and "internal error" not in log


def test_a_controller_refuses_tolerances_for_joints_it_does_not_drive(client: Client) -> None:
    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import JointTolerance

    from interfaces_py.action_client import ActionClient

    response = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(READY)).motion_plan_response
    assert response.error_code.val == C.SUCCESS
    controller = ActionClient(client.node, FollowJointTrajectory, "/arm_controller/follow_joint_trajectory")
    assert controller.wait_for_server(10.0)
    goal = FollowJointTrajectory.Goal(trajectory=response.trajectory.joint_trajectory)
    goal.goal_tolerance = [JointTolerance(name="nojoint", position=0.01)]
    handle = client.spin_until(controller.send_goal_async(goal))
    assert not handle.accepted


# ----------------------------------------------------------------------------- cancel and results
def _long_plan_goal() -> MoveGroup.Goal:
    """A plan that runs its whole allowed_planning_time, 60 s: from all zeros to FAR with the
    flange kept inside one of two 1 cm spheres, one around each end (a path constraint both ends
    satisfy and no path does), so the planner searches until its time is up."""
    model = RobotModel.mycobot()
    goal = _move_goal(FAR)
    goal.request.start_state.joint_state.name = list(ARM)
    goal.request.start_state.joint_state.position = [0.0] * len(ARM)
    region = PositionConstraint(link_name="link6_flange")
    region.header.frame_id = "world"
    for values in ([0.0] * len(ARM), FAR):
        state = RobotState(model)
        state.set_joint_positions(dict(zip(ARM, values)))
        centre = Pose()
        centre.position.x, centre.position.y, centre.position.z = (float(v) for v in state.frame_pose("link6_flange")[:3, 3])
        centre.orientation.w = 1.0
        region.constraint_region.primitives.append(SolidPrimitive(type=SolidPrimitive.SPHERE, dimensions=[0.01]))
        region.constraint_region.primitive_poses.append(centre)
    goal.request.path_constraints = Constraints(position_constraints=[region])
    goal.request.allowed_planning_time = 60.0
    return goal


def test_cancel_during_planning_stops_the_plan(client: Client) -> None:
    states: list[str] = []
    handle = client.send(client.move, _long_plan_goal(), feedback=lambda m: states.append(m.feedback.state))
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.01), "PLANNING" in states)[1], 20.0,
                      period=0.0)
    client.spin_until(handle.cancel_goal_async())
    response = client.spin_until(handle.get_result_async(), timeout=20.0)  # far less than the 60 s plan
    assert response.status == GoalStatus.STATUS_CANCELED
    assert response.result.error_code.val == C.PREEMPTED
    assert "cancel" in response.result.error_code.message  # the planner was stopped, it did not fail


def test_cancelling_one_goal_leaves_the_others_planning(client: Client) -> None:
    """Three goals plan at once; the one cancelled ends PREEMPTED, the two others succeed."""
    handles = [client.send(client.move, _move_goal(FAR)) for _ in range(2)]
    cancelled = client.send(client.move, _long_plan_goal())
    client.spin_until(cancelled.cancel_goal_async())
    assert client.spin_until(cancelled.get_result_async(), timeout=20.0).status == GoalStatus.STATUS_CANCELED
    for handle in handles:
        assert client.spin_until(handle.get_result_async()).result.error_code.val == C.SUCCESS


def test_a_storm_of_goals_loses_no_result(client: Client) -> None:
    """20 plan-only goals at once, their results asked for together once they are done: all 20
    answer (rclpy's default depth of 10 for the result service lost half of them)."""
    from rclpy.qos import QoSProfile

    from interfaces_py.action_client import ActionClient

    # the client keeps every response too (with rclpy's default depth of 10, its own queue drops some)
    deep = {f"{kind}_service_qos_profile": QoSProfile(depth=100) for kind in ("goal", "result", "cancel")}
    storm = ActionClient(client.node, MoveGroup, "/move_action", **deep)
    handles = [client.send(storm, _move_goal(FAR if k % 2 else READY)) for k in range(20)]
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.05),
                               all(h.status == GoalStatus.STATUS_SUCCEEDED for h in handles))[1], 60.0, period=0.0)
    futures = [handle.get_result_async() for handle in handles]  # all finished: asked at once
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.05), all(f.done() for f in futures))[1], 30.0,
                      period=0.0), f"{sum(not f.done() for f in futures)} of 20 results never came"
    done = [f.result().result.error_code.val for f in futures]
    assert done == [C.SUCCESS] * 20


def test_sigterm_answers_the_running_goals_and_exits(client: Client) -> None:
    """Last in the module: it ends the planning_server. A plan in progress and an execution in
    progress both get their results (PREEMPTED), the process exits on its own, no traceback."""
    import signal

    from moveit_msgs.action import ExecuteTrajectory

    trajectory = client.call(GetMotionPlan, "/plan_kinematic_path", joint_goal(FAR)).motion_plan_response.trajectory
    slow = trajectory.joint_trajectory
    for point in slow.points:  # the same path, ten times slower: still running when SIGTERM comes
        ns = (point.time_from_start.sec * 1_000_000_000 + point.time_from_start.nanosec) * 10
        point.time_from_start.sec, point.time_from_start.nanosec = ns // 1_000_000_000, ns % 1_000_000_000
        point.velocities = [v / 10 for v in point.velocities]
        point.accelerations = [a / 100 for a in point.accelerations]
    states: list[str] = []
    executing = client.send(client.execute, ExecuteTrajectory.Goal(trajectory=trajectory),
                            feedback=lambda m: states.append(m.feedback.state))
    planning = client.send(client.move, _long_plan_goal(), feedback=lambda m: states.append(m.feedback.state))
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.01), "PLANNING" in states)[1], 20.0,
                      period=0.0)
    results = [executing.get_result_async(), planning.get_result_async()]
    client.server.proc.send_signal(signal.SIGTERM)
    assert wait_until(lambda: (client.executor.spin_once(timeout_sec=0.05), all(f.done() for f in results))[1], 10.0,
                      period=0.0), "a client got no answer"
    for future in results:
        assert future.result().status in (GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED)
        assert future.result().result.error_code.val == C.PREEMPTED, future.result().result.error_code.message
    assert client.server.proc.wait(timeout=10.0) == 0
    output = client.server.output()
    assert "Traceback" not in output, output[max(0, output.find("Traceback") - 1500):]
